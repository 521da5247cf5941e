//! Topology checks of the kept set: boundary triangles, pinched edges and
//! vertices, face-connected components.

use super::*;

/// Boundary triangles (vertex triples) of a mesh, from its adjacency.
pub(super) fn boundary_triangles(mesh: &TetMesh, adj: &Adjacency) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for (t, nb) in adj.neighbors.iter().enumerate() {
        for (f, &n) in nb.iter().enumerate() {
            if n == NO_NEIGHBOR {
                let s = FACE_VERTICES[f];
                let tet = mesh.tets[t];
                out.push([tet[s[0]], tet[s[1]], tet[s[2]]]);
            }
        }
    }
    out
}

/// Where the boundary triangles `tris` are not a closed 2-manifold: edges
/// not shared by exactly two triangles, and vertices whose triangles form
/// more than one fan; both sorted.
pub(super) fn boundary_defects(tris: &[[u32; 3]]) -> (Vec<[u32; 2]>, Vec<u32>) {
    let mut edges: Vec<[u32; 2]> = Vec::with_capacity(tris.len() * 3);
    for t in tris {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            edges.push([a.min(b), a.max(b)]);
        }
    }
    edges.par_sort_unstable();
    let mut bad_edges = Vec::new();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i != 2 {
            bad_edges.push(edges[i]);
        }
        i = j;
    }
    // Vertex links: for each boundary vertex, the opposite edges of its triangles.
    let mut link: Vec<(u32, u32, u32)> = Vec::with_capacity(tris.len() * 3);
    for t in tris {
        link.push((t[0], t[1], t[2]));
        link.push((t[1], t[2], t[0]));
        link.push((t[2], t[0], t[1]));
    }
    link.par_sort_unstable();
    let mut bad_vertices = Vec::new();
    let mut i = 0;
    while i < link.len() {
        let mut j = i + 1;
        while j < link.len() && link[j].0 == link[i].0 {
            j += 1;
        }
        // Count connected components of the link graph.
        let pairs: Vec<(u32, u32)> = link[i..j].iter().map(|x| (x.1, x.2)).collect();
        let mut seen = vec![false; pairs.len()];
        let mut components = 0;
        for s in 0..pairs.len() {
            if seen[s] {
                continue;
            }
            components += 1;
            seen[s] = true;
            let mut stack = vec![s];
            while let Some(e) = stack.pop() {
                for f in 0..pairs.len() {
                    if !seen[f] {
                        let (a, b) = pairs[e];
                        let (c, d) = pairs[f];
                        if a == c || a == d || b == c || b == d {
                            seen[f] = true;
                            stack.push(f);
                        }
                    }
                }
            }
        }
        if components > 1 {
            bad_vertices.push(link[i].0);
        }
        i = j;
    }
    (bad_edges, bad_vertices)
}

/// Face-connected components: a component id per tetrahedron, numbered in
/// order of their first tetrahedron (the generator's own check works on the
/// lattice: `clean.rs`).
#[cfg(test)]
pub(super) fn components(adj: &Adjacency) -> (Vec<u32>, usize) {
    let n = adj.neighbors.len();
    let mut comp = vec![u32::MAX; n];
    let mut count = 0;
    for s in 0..n {
        if comp[s] != u32::MAX {
            continue;
        }
        comp[s] = count as u32;
        let mut stack = vec![s];
        while let Some(t) = stack.pop() {
            for &nb in &adj.neighbors[t] {
                if nb != NO_NEIGHBOR && comp[nb as usize] == u32::MAX {
                    comp[nb as usize] = count as u32;
                    stack.push(nb as usize);
                }
            }
        }
        count += 1;
    }
    (comp, count)
}
