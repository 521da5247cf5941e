//! The load path's renumbering (`data::locality`): the radix sort is the
//! sort, a local numbering is kept, a scattered one is renumbered along the
//! Morton curve with the same cells and fields, a `.pvtu`'s cells stay in
//! their pieces, and the random permutation of `generate permuted` is
//! seeded.

use pvrsim::data::lattice::kuhn_tets;
use pvrsim::data::locality::*;
use pvrsim::data::{Field, TetMesh};

/// A lattice of `n^3` cubes (Kuhn tets) in lattice order, with a field
/// `x + 2y + 3z` and a 3-component one.
fn lattice(n: usize) -> TetMesh {
    let m = n + 1;
    let points: Vec<[f64; 3]> = (0..m * m * m)
        .map(|i| [(i % m) as f64, ((i / m) % m) as f64, (i / (m * m)) as f64])
        .collect();
    let s: Vec<f64> = points
        .iter()
        .map(|p| p[0] + 2.0 * p[1] + 3.0 * p[2])
        .collect();
    let v: Vec<f64> = points.iter().flat_map(|p| [p[2], p[1], p[0]]).collect();
    TetMesh {
        tets: kuhn_tets([n; 3], |_, _, _| true),
        points,
        fields: vec![
            Field {
                name: "s".into(),
                components: 1,
                values: s,
            },
            Field {
                name: "v".into(),
                components: 3,
                values: v,
            },
        ],
    }
}

/// Each cell as its sorted vertices (position and field values, as bits),
/// sorted: equal for the same cells whatever the numbering.
fn cells(m: &TetMesh) -> Vec<[[u64; 7]; 4]> {
    let mut out: Vec<[[u64; 7]; 4]> = m
        .tets
        .iter()
        .map(|t| {
            let mut c = t.map(|i| {
                let i = i as usize;
                let p = m.points[i];
                let v = &m.fields[1].values[3 * i..3 * i + 3];
                [p[0], p[1], p[2], m.fields[0].values[i], v[0], v[1], v[2]].map(f64::to_bits)
            });
            c.sort_unstable();
            c
        })
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn sort_keys_is_the_sort() {
    let mut s = 7u64;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        s >> 32
    };
    // Distinct values (distinct indices), keys spread or crowded in a few
    // buckets, of sizes below and above the small-slice cut.
    for (n, spread_bits) in [
        (10, 30),
        (5000, 30),
        (200_000, 32),
        (100_000, 12),
        (70_000, 25),
    ] {
        let mut v: Vec<u64> = (0..n as u64)
            .map(|i| ((next() & ((1 << spread_bits) - 1)) << (64 - spread_bits)) | i)
            .collect();
        let mut want = v.clone();
        want.sort_unstable();
        sort_keys(&mut v);
        assert_eq!(v, want, "n {n}, {spread_bits} bits");
    }
}

#[test]
fn lattice_order_is_local_and_kept() {
    let m = lattice(44); // 91,125 vertices: more than WINDOW
    assert!(m.points.len() as u64 > WINDOW);
    assert!(locality(&m) > 0.99, "{}", locality(&m));
    let mut k = m.clone();
    assert_eq!(make_local(&mut k, None).1, None);
    assert_eq!(k, m);
}

#[test]
fn a_permuted_mesh_is_renumbered_local_with_the_same_cells() {
    let m = lattice(44);
    let mut p = m.clone();
    permute(&mut p, 1);
    assert!(locality(&p) < LOCAL_FRACTION, "{}", locality(&p));
    assert_eq!(cells(&p), cells(&m));
    p.validate(std::path::Path::new("p")).unwrap();
    let r = make_local(&mut p, None).1.expect("renumbered");
    assert!(locality(&p) >= LOCAL_FRACTION, "{}", locality(&p));
    assert_eq!(cells(&p), cells(&m));
    p.validate(std::path::Path::new("p")).unwrap();
    // A permutation of each, and the renumbering is by the Morton key: a
    // vertex's key never decreases along the new numbering.
    let mut v = r.vertices.clone();
    v.sort_unstable();
    assert!(v.iter().enumerate().all(|(i, &x)| i as u32 == x));
    let mut c = r.cells.clone();
    c.sort_unstable();
    assert!(c.iter().enumerate().all(|(i, &x)| i as u32 == x));
    let (lo, hi) = p.bounds();
    let q = Quantizer::new(lo, hi);
    assert!(p.points.windows(2).all(|w| q.key(w[0]) <= q.key(w[1])));
    // Cells by their lowest vertex.
    let low = |t: &[u32; 4]| *t.iter().min().unwrap();
    assert!(p.tets.windows(2).all(|w| low(&w[0]) <= low(&w[1])));
}

#[test]
fn pieces_keep_their_cells() {
    let m = lattice(44);
    let mut p = m.clone();
    permute(&mut p, 2);
    let n = p.tets.len() as u64;
    let pieces = [n / 3, n / 3, n - 2 * (n / 3)];
    let before: Vec<TetMesh> = piece_meshes(&p, &pieces);
    let r = make_local(&mut p, Some(&pieces)).1.expect("renumbered");
    let mut start = 0;
    for &len in &pieces {
        let end = start + len as usize;
        assert!(r.cells[start..end]
            .iter()
            .all(|&c| (start..end).contains(&(c as usize))));
        start = end;
    }
    let after = piece_meshes(&p, &pieces);
    for (a, b) in after.iter().zip(&before) {
        assert_eq!(cells(a), cells(b));
    }
}

/// Each piece's cells as a mesh of all the vertices.
fn piece_meshes(m: &TetMesh, pieces: &[u64]) -> Vec<TetMesh> {
    let mut start = 0;
    pieces
        .iter()
        .map(|&len| {
            let end = start + len as usize;
            let mut p = m.clone();
            p.tets = m.tets[start..end].to_vec();
            start = end;
            p
        })
        .collect()
}

#[test]
fn permute_is_seeded() {
    let m = lattice(3);
    let (mut a, mut b, mut c) = (m.clone(), m.clone(), m.clone());
    permute(&mut a, 5);
    permute(&mut b, 5);
    permute(&mut c, 6);
    assert_eq!(a, b);
    assert_ne!(a, c);
    assert_eq!(cells(&a), cells(&m));
}
