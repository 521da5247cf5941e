//! The union of a partitioned mesh's pieces: concatenation, then the
//! merge of the vertices the pieces duplicate on their shared boundaries.

use rayon::prelude::*;

use crate::data::{Field, TetMesh};

/// The pieces one after the other (vertex indices offset); fields in the
/// first piece's order (the caller has checked that all pieces agree).
pub fn concat(parts: Vec<TetMesh>) -> TetMesh {
    let mut out = TetMesh::default();
    let np: usize = parts.iter().map(|m| m.points.len()).sum();
    let nt: usize = parts.iter().map(|m| m.tets.len()).sum();
    out.points.reserve(np);
    out.tets.reserve(nt);
    if let Some(first) = parts.iter().find(|m| !m.points.is_empty()) {
        out.fields = first
            .fields
            .iter()
            .map(|f| Field {
                name: f.name.clone(),
                components: f.components,
                values: Vec::with_capacity(np * f.components),
            })
            .collect();
    }
    for m in parts {
        let base = out.points.len() as u32;
        out.tets.extend(m.tets.iter().map(|t| t.map(|v| v + base)));
        out.points.extend_from_slice(&m.points);
        for (o, f) in out.fields.iter_mut().zip(&m.fields) {
            o.values.extend_from_slice(&f.values);
        }
    }
    out
}

/// Merges vertices equal bit for bit in position and in every field value;
/// the kept copy is the first (lowest index), the vertex order otherwise
/// unchanged. Returns the mesh unchanged when nothing is duplicated.
pub fn merge_shared(mut mesh: TetMesh) -> TetMesh {
    let n = mesh.points.len();
    let key = |v: usize| mesh.points[v].map(f64::to_bits);
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.par_sort_unstable_by_key(|&v| (key(v as usize), v));
    let same_values = |a: usize, b: usize| {
        mesh.fields.iter().all(|f| {
            let c = f.components;
            (0..c).all(|k| f.values[a * c + k].to_bits() == f.values[b * c + k].to_bits())
        })
    };
    let mut rep: Vec<u32> = (0..n as u32).collect();
    let mut merged = 0usize;
    let mut i = 0;
    while i < n {
        let mut j = i + 1;
        while j < n && key(order[j] as usize) == key(order[i] as usize) {
            j += 1;
        }
        for b in i + 1..j {
            let vb = order[b] as usize;
            if let Some(&va) = order[i..b]
                .iter()
                .find(|&&va| rep[va as usize] == va && same_values(va as usize, vb))
            {
                rep[vb] = va;
                merged += 1;
            }
        }
        i = j;
    }
    if merged == 0 {
        return mesh;
    }
    let mut new_index = vec![u32::MAX; n];
    let mut kept = 0u32;
    for v in 0..n {
        if rep[v] == v as u32 {
            new_index[v] = kept;
            kept += 1;
        }
    }
    mesh.tets
        .par_iter_mut()
        .for_each(|t| *t = t.map(|v| new_index[rep[v as usize] as usize]));
    let keep = |v: &usize| rep[*v] == *v as u32;
    mesh.points = (0..n).filter(keep).map(|v| mesh.points[v]).collect();
    for f in &mut mesh.fields {
        let c = f.components;
        f.values = (0..n)
            .filter(keep)
            .flat_map(|v| f.values[v * c..(v + 1) * c].to_vec())
            .collect();
        f.values.shrink_to_fit();
    }
    mesh.points.shrink_to_fit();
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tet(offset: f64, value: f64) -> TetMesh {
        TetMesh {
            points: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0 + offset],
            ],
            tets: vec![[0, 1, 2, 3]],
            fields: vec![Field {
                name: "s".into(),
                components: 1,
                values: vec![value, 1.0, 2.0, 3.0],
            }],
        }
    }

    #[test]
    fn shared_vertices_merge_and_differing_ones_do_not() {
        // Two tets sharing the face 1 2 3 (the second mirrored), vertex 0 of
        // the second with another value: 3 shared, 2 kept apart.
        let mut b = tet(0.0, 9.0);
        b.points[0] = [1.0, 1.0, 1.0];
        let m = merge_shared(concat(vec![tet(0.0, 0.0), b]));
        assert_eq!(m.points.len(), 5);
        assert_eq!(m.tets, vec![[0, 1, 2, 3], [4, 1, 2, 3]]);
        assert_eq!(m.fields[0].values, vec![0.0, 1.0, 2.0, 3.0, 9.0]);
        // Same positions, different values: nothing merged.
        let mut c = tet(0.0, 0.0);
        c.fields[0].values = vec![5.0, 6.0, 7.0, 8.0];
        let m = merge_shared(concat(vec![tet(0.0, 0.0), c]));
        assert_eq!(m.points.len(), 8);
    }
}
