//! Partitioned meshes (`.pvtu`): VTK 9.7.2's own pieces of the small aorta
//! read back as the unpartitioned mesh, our writer's round trip, the
//! partitioner's properties, and bad input (each a clear error naming the
//! piece, a non-zero exit, no panic).

use std::path::Path;
use std::process::Command;

mod cli_support;
use cli_support::{copy_vtk_pieces, data, pvrsim};

use proptest::prelude::*;
use pvrsim::data::io::pvtu::write::{write_pvtu, Encoding};
use pvrsim::data::io::read_mesh;
use pvrsim::data::partition::{partition, partition_points};
use pvrsim::data::{Field, TetMesh};

/// Each tetrahedron as its four sorted vertex positions (bits), sorted:
/// equal for two meshes with the same cells whatever their numbering.
fn cell_set(m: &TetMesh) -> Vec<[[u64; 3]; 4]> {
    let mut v: Vec<[[u64; 3]; 4]> = m
        .tets
        .iter()
        .map(|t| {
            let mut c = t.map(|i| m.points[i as usize].map(f64::to_bits));
            c.sort_unstable();
            c
        })
        .collect();
    v.sort_unstable();
    v
}

/// Each vertex as (position bits, field value bits), sorted.
fn vertex_set(m: &TetMesh) -> Vec<Vec<u64>> {
    let mut v: Vec<Vec<u64>> = (0..m.points.len())
        .map(|i| {
            let mut k: Vec<u64> = m.points[i].iter().map(|x| x.to_bits()).collect();
            for f in &m.fields {
                let c = f.components;
                k.extend(f.values[i * c..(i + 1) * c].iter().map(|x| x.to_bits()));
            }
            k
        })
        .collect();
    v.sort_unstable();
    v
}

#[test]
fn vtk_pieces_union_is_the_unpartitioned_mesh() {
    let whole = read_mesh(&data("aorta-small.vtk")).unwrap();
    for enc in ["raw", "zlib"] {
        let m = read_mesh(&data(&format!("pieces/aorta-small-{enc}.pvtu"))).unwrap();
        // The boundary vertices VTK duplicated are merged back.
        assert_eq!(m.points.len(), whole.points.len(), "{enc}");
        assert_eq!(m.tets.len(), whole.tets.len(), "{enc}");
        let names: Vec<&str> = m.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["velocity", "speed", "pressure", "potential"]);
        assert_eq!(cell_set(&m), cell_set(&whole), "{enc}");
        assert_eq!(vertex_set(&m), vertex_set(&whole), "{enc}");
        let a = m.adjacency();
        let b = whole.adjacency();
        let boundary = |a: &pvrsim::data::Adjacency| {
            a.neighbors
                .iter()
                .flatten()
                .filter(|&&n| n == pvrsim::data::NO_NEIGHBOR)
                .count()
        };
        assert_eq!(boundary(&a), boundary(&b), "{enc}: piece seams closed");
    }
}

/// A copy of VTK's zlib pieces (appended base64) in a temporary folder, `edit`ed.
fn copy_pieces(edit: impl FnOnce(&Path)) -> tempfile::TempDir {
    copy_encoded("zlib", edit)
}

/// A copy of VTK's `enc` (raw, zlib) pieces as `a.pvtu`, `edit`ed.
fn copy_encoded(enc: &str, edit: impl FnOnce(&Path)) -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    copy_vtk_pieces(enc, d.path());
    edit(d.path());
    d
}

/// A copy of VTK's zlib pieces with the first `from` in file `name` (a
/// piece or `a.pvtu`) replaced by `to`.
fn with_replaced(name: &str, from: &str, to: &str) -> tempfile::TempDir {
    copy_pieces(|d| replace_in(&d.join(name), from, to))
}

/// A copy of VTK's `enc` pieces with piece `k`'s file cut 5000 bytes short.
fn with_truncated(enc: &str, k: usize) -> tempfile::TempDir {
    copy_encoded(enc, |d| {
        let p = d.join(format!("aorta-small-{enc}_{k}.vtu"));
        let b = std::fs::read(&p).unwrap();
        std::fs::write(&p, &b[..b.len() - 5000]).unwrap();
    })
}

fn replace_in(p: &Path, from: &str, to: &str) {
    let s = std::fs::read(p).unwrap();
    let f = from.as_bytes();
    let i = s.windows(f.len()).position(|w| w == f).expect(from);
    let mut out = s[..i].to_vec();
    out.extend_from_slice(to.as_bytes());
    out.extend_from_slice(&s[i + f.len()..]);
    std::fs::write(p, out).unwrap();
}

fn info_fails(dir: &Path, expect: &[&str]) {
    let p = dir.join("a.pvtu");
    let (ok, err) = pvrsim(&["info", p.to_str().unwrap(), "--no-quality"]);
    assert!(!ok, "should fail: {err}");
    for e in expect {
        assert!(err.contains(e), "expected {e:?} in: {err}");
    }
}

#[test]
fn the_copy_reads() {
    let d = copy_pieces(|_| {});
    let (ok, err) = pvrsim(&["info", d.path().join("a.pvtu").to_str().unwrap()]);
    assert!(ok, "{err}");
}

#[test]
fn a_missing_piece_is_named() {
    let d = copy_pieces(|d| std::fs::remove_file(d.join("aorta-small-zlib_2.vtu")).unwrap());
    info_fails(d.path(), &["<Piece> 2", "aorta-small-zlib_2.vtu"]);
}

#[test]
fn a_piece_with_other_fields_is_named() {
    let d = with_replaced(
        "aorta-small-zlib_1.vtu",
        "Name=\"pressure\"",
        "Name=\"presure!\"",
    );
    info_fails(d.path(), &["<Piece> 1", "presure!", "<PPointData>"]);
}

#[test]
fn a_piece_with_another_type_is_named() {
    let d = with_replaced(
        "a.pvtu",
        "type=\"Float32\" Name=\"speed\"",
        "type=\"Float64\" Name=\"speed\"",
    );
    info_fails(d.path(), &["<Piece> 0", "speed", "F64"]);
}

#[test]
fn a_piece_outside_the_folder_is_refused_unless_allowed() {
    // The pieces in `d`, the .pvtu naming them in `d/sub`.
    let d = copy_pieces(|_| {});
    let sub = d.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    let text = std::fs::read_to_string(data("pieces/aorta-small-zlib.pvtu"))
        .unwrap()
        .replace("Source=\"aorta", "Source=\"../aorta");
    std::fs::write(sub.join("a.pvtu"), &text).unwrap();
    info_fails(&sub, &["<Piece> 0", "outside", "PVRSIM_DATA_FILE_ANYWHERE"]);
    let abs = std::fs::read_to_string(data("pieces/aorta-small-zlib.pvtu"))
        .unwrap()
        .replace(
            "Source=\"aorta",
            &format!("Source=\"{}/aorta", d.path().display()),
        );
    std::fs::write(sub.join("a.pvtu"), &abs).unwrap();
    info_fails(&sub, &["<Piece> 0", "outside"]);
    let out = Command::new(env!("CARGO_BIN_EXE_pvrsim"))
        .args(["info", sub.join("a.pvtu").to_str().unwrap(), "--no-quality"])
        .env("PVRSIM_DATA_FILE_ANYWHERE", "1")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_truncated_piece_is_named() {
    // Raw appended data cut short.
    let d = with_truncated("raw", 3);
    info_fails(
        d.path(),
        &["<Piece> 3", "aorta-small-raw_3.vtu", "truncated"],
    );
    // zlib blocks in base64 (as VTK writes them) cut short.
    let d = with_truncated("zlib", 3);
    info_fails(d.path(), &["<Piece> 3", "aorta-small-zlib_3.vtu", "base64"]);
}

#[test]
fn out_of_range_indices_are_named() {
    // A piece of ours (raw Int32 connectivity) with one index past its points.
    let d = tempfile::tempdir().unwrap();
    let whole = read_mesh(&data("aorta-small.vtk")).unwrap();
    let out = d.path().join("a.pvtu");
    write_pvtu(&whole, &partition(&whole, 3), Encoding::Raw, &out).unwrap();
    let p = d.path().join("a_1.vtu");
    let b = std::fs::read(&p).unwrap();
    let np: usize = {
        let s = String::from_utf8_lossy(&b);
        let i = s.find("NumberOfPoints=\"").unwrap() + 16;
        s[i..].split('"').next().unwrap().parse().unwrap()
    };
    // The connectivity follows the marker, the fields and the points.
    let s = String::from_utf8_lossy(&b);
    let off: usize = {
        let i = s.find("Name=\"connectivity\"").unwrap();
        let j = s[i..].find("offset=\"").unwrap() + i + 8;
        s[j..].split('"').next().unwrap().parse().unwrap()
    };
    let marker = b.windows(2).position(|w| w == b" _").unwrap() + 2;
    let at = marker + off + 8 + 4 * 5; // header, then cell 1's second index
    let mut b2 = b.clone();
    b2[at..at + 4].copy_from_slice(&(np as i32 + 7).to_le_bytes());
    std::fs::write(&p, b2).unwrap();
    info_fails(d.path(), &["<Piece> 1", "a_1.vtu", "out of range"]);
}

#[test]
fn a_pvtu_scene_renders_like_the_whole_mesh() {
    let d = tempfile::tempdir().unwrap();
    let scene = std::fs::read_to_string(data("aorta-small-view-b.toml")).unwrap();
    let whole_scene = d.path().join("whole.toml");
    std::fs::copy(data("aorta-small.vtk"), d.path().join("aorta-small.vtk")).unwrap();
    std::fs::write(&whole_scene, &scene).unwrap();
    let whole = read_mesh(&data("aorta-small.vtk")).unwrap();
    write_pvtu(
        &whole,
        &partition(&whole, 4),
        Encoding::Zlib,
        &d.path().join("p.pvtu"),
    )
    .unwrap();
    let piece_scene = d.path().join("pieces.toml");
    std::fs::write(
        &piece_scene,
        scene.replace("path  = \"aorta-small.vtk\"", "path  = \"p.pvtu\""),
    )
    .unwrap();
    assert!(std::fs::read_to_string(&piece_scene)
        .unwrap()
        .contains("p.pvtu"));
    let render = |s: &Path, o: &str| {
        let (ok, err) = pvrsim(&[
            "render",
            s.to_str().unwrap(),
            "-o",
            d.path().join(o).to_str().unwrap(),
            "--canonical",
            "--ert",
            "1",
        ]);
        assert!(ok, "{err}");
        std::fs::read(d.path().join(o)).unwrap()
    };
    assert_eq!(render(&whole_scene, "w.png"), render(&piece_scene, "p.png"));
}

fn small_mesh(n: usize, seed: u64) -> TetMesh {
    // A jittered lattice strip of points, tetrahedra over random quadruples.
    let mut s = seed | 1;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let np = n + 4;
    let points: Vec<[f64; 3]> = (0..np)
        .map(|i| {
            let j = (rnd() % 1000) as f64 / 1000.0;
            [
                (i % 7) as f64 + j,
                ((i / 7) % 5) as f64,
                (i / 35) as f64 * 0.5,
            ]
        })
        .collect();
    let tets = (0..n)
        .map(|_| {
            let a = (rnd() % (np as u64 - 3)) as u32;
            [a, a + 1, a + 2, a + 3]
        })
        .collect();
    let values = (0..np).map(|i| i as f32 as f64 * 0.25).collect();
    TetMesh {
        points,
        tets,
        fields: vec![Field {
            name: "s v".into(),
            components: 1,
            values,
        }],
    }
}

/// A mesh of `cells` tetrahedra on scattered points (ties in coordinates
/// included), for cuts by centroid.
fn scattered_mesh(cells: usize, seed: u64) -> pvrsim::data::TetMesh {
    let mut x = seed | 1;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % 64) as f64 * 0.5
    };
    let points: Vec<[f64; 3]> = (0..64).map(|_| [next(), next(), next()]).collect();
    let tets = (0..cells)
        .map(|i| {
            let a = (i * 7 % 61) as u32;
            [a, a + 1, a + 2, (a + 3) % 64]
        })
        .collect();
    pvrsim::data::TetMesh {
        points,
        tets,
        ..Default::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// The pieces' runs: every piece on exactly one node, each node's
    /// pieces one ascending run and the runs in node order, no node empty
    /// when there are as many pieces as nodes; the placement from them
    /// holds every cell once, a node's cells being its pieces' (or, with
    /// fewer pieces than nodes, its part of a split piece: as many cells as
    /// the piece map's unit says, every node one unit).
    #[test]
    fn piece_runs_cover_in_order(w in prop::collection::vec(0u64..500, 1..40), n in 1usize..20, seed in any::<u64>()) {
        use pvrsim::node::piece_map::{shares, unit_weights};
        use pvrsim::node::placement::piece_runs;
        let runs = piece_runs(&w, n);
        prop_assert_eq!(runs.len(), n);
        let flat: Vec<u32> = runs.iter().flatten().copied().collect();
        prop_assert_eq!(flat, (0..w.len() as u32).collect::<Vec<_>>());
        if w.len() >= n {
            prop_assert!(runs.iter().all(|r| !r.is_empty()), "{:?}", runs);
        }
        let total: u64 = w.iter().sum();
        let mesh = scattered_mesh(total as usize, seed);
        let p = pvrsim::node::piece_map::place(&mesh, &w, n);
        let mut cells: Vec<u32> = p.parts.iter().flatten().copied().collect();
        cells.sort_unstable();
        prop_assert_eq!(cells, (0..total as u32).collect::<Vec<_>>());
        prop_assert!(p.parts.iter().all(|q| q.windows(2).all(|x| x[0] < x[1])));
        let units = shares(&w, n);
        if w.len() >= n || total == 0 {
            prop_assert_eq!(units.len(), w.len());
            for (run, part) in runs.iter().zip(&p.parts) {
                let want: u64 = run.iter().map(|&i| w[i as usize]).sum();
                prop_assert_eq!(part.len() as u64, want);
            }
        } else {
            prop_assert_eq!(units.len(), n);
            let uw = unit_weights(&w, &units);
            for (k, part) in p.parts.iter().enumerate() {
                prop_assert_eq!(part.len() as u64, uw[k], "node {}", k);
            }
            // Every piece has a node.
            for i in 0..w.len() as u32 {
                prop_assert!(units.iter().any(|u| u.piece == i));
            }
        }
    }

    /// Every cell in exactly one piece; sizes within one cell of the
    /// share; the pieces' centroid boxes together no larger than the whole
    /// box (pieces from a bisection do not overlap; random pieces would
    /// each span nearly all of it).
    #[test]
    fn partition_covers_and_is_coherent(n in 50usize..3000, pieces in 1usize..12, seed in any::<u64>()) {
        let mut s = seed | 1;
        let pts: Vec<[f64; 3]> = (0..n).map(|_| {
            let mut c = [0.0; 3];
            for v in &mut c {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                *v = (s % 100_000) as f64 / 1000.0;
            }
            c
        }).collect();
        let parts = partition_points(&pts, pieces);
        prop_assert_eq!(parts.len(), pieces);
        let mut seen = vec![0u8; n];
        for p in &parts {
            for &c in p {
                seen[c as usize] += 1;
            }
        }
        prop_assert!(seen.iter().all(|&k| k == 1));
        let lo = n / pieces;
        prop_assert!(parts.iter().all(|p| p.len() >= lo.saturating_sub(1) && p.len() <= lo + 2));
        let bbox = |ids: &mut dyn Iterator<Item = usize>| {
            let mut l = [f64::INFINITY; 3];
            let mut h = [f64::NEG_INFINITY; 3];
            for i in ids {
                for k in 0..3 { l[k] = l[k].min(pts[i][k]); h[k] = h[k].max(pts[i][k]); }
            }
            (0..3).map(|k| (h[k] - l[k]).max(0.0)).product::<f64>()
        };
        let whole = bbox(&mut (0..n));
        let sum: f64 = parts.iter().map(|p| bbox(&mut p.iter().map(|&c| c as usize))).sum();
        prop_assert!(sum <= whole * (1.0 + 1e-9), "sum of piece boxes {} > whole {}", sum, whole);
    }

    /// Pieces written (raw or zlib) and read back give the mesh's cells and
    /// vertices exactly (shared vertices merged back).
    #[test]
    fn pieces_round_trip(n in 10usize..400, pieces in 1usize..6, zlib in any::<bool>(), seed in any::<u64>()) {
        let m = small_mesh(n, seed);
        let pieces = pieces.min(n);
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("m.pvtu");
        let enc = if zlib { Encoding::Zlib } else { Encoding::Raw };
        write_pvtu(&m, &partition(&m, pieces), enc, &out).unwrap();
        let r = read_mesh(&out).unwrap();
        // Vertices no cell uses are not written.
        let mut used = vec![false; m.points.len()];
        for t in &m.tets { for &v in t { used[v as usize] = true; } }
        let mut compact = m.clone();
        compact.points = (0..m.points.len()).filter(|&v| used[v]).map(|v| m.points[v]).collect();
        compact.fields[0].values = (0..m.points.len()).filter(|&v| used[v]).map(|v| m.fields[0].values[v]).collect();
        let mut idx = vec![0u32; m.points.len()];
        let mut k = 0;
        for v in 0..m.points.len() { if used[v] { idx[v] = k; k += 1; } }
        compact.tets = m.tets.iter().map(|t| t.map(|v| idx[v as usize])).collect();
        prop_assert_eq!(r.tets.len(), m.tets.len());
        prop_assert_eq!(cell_set(&r), cell_set(&compact));
        prop_assert_eq!(vertex_set(&r), vertex_set(&compact));
        prop_assert_eq!(&r.fields[0].name, "s v");
    }
}
