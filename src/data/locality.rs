//! Locality of a mesh's numbering, whatever order the file was written in:
//! the load path ([`crate::data::io::read_mesh_with_pieces`]) renumbers
//! vertices and cells once along a Morton (Z-order) curve over the bounding
//! box when a cheap sample shows the file's numbering scattered
//! ([`is_local`]), so that projection and scan gather a cell's vertices
//! from cache. Meshes already local (the shared scenes, pvrsim's generated
//! meshes, a mesher writing in a sweep order) keep their numbering, so
//! their images are unchanged.
//!
//! Vertices are keyed by the 30-bit Morton code of their position (10 bits
//! an axis), cells by their lowest vertex in the new numbering; each key is
//! packed above the 32-bit index into one `u64` and sorted by a radix sort
//! (one most-significant pass over the whole array, then two
//! least-significant passes in each of its 1024 buckets, the buckets in
//! parallel): the order is by key, then by the file's index, so it is
//! deterministic.

use rayon::prelude::*;

use crate::data::TetMesh;

/// A cell is local when its vertex indices span fewer than this many
/// vertices and its lowest index is within this many of the previous
/// cell's: 65,536 vertices hold 2 MB of positions and scalars.
pub const WINDOW: u64 = 1 << 16;

/// Cells sampled by [`locality`]: `RUNS` runs of `RUN` consecutive cells,
/// evenly spread over the file.
const RUNS: usize = 256;
const RUN: usize = 256;

/// The fraction of sampled cells [`is_local`] asks to be local.
pub const LOCAL_FRACTION: f64 = 0.9;

/// The fraction of a sample of cells that are local ([`WINDOW`]): about
/// 65,000 cells in runs of consecutive ones, so it reads a few MB
/// whatever the mesh's size. 1 for a mesh of at most [`WINDOW`] vertices.
pub fn locality(mesh: &TetMesh) -> f64 {
    let n = mesh.tets.len();
    if n < 2 || mesh.points.len() as u64 <= WINDOW {
        return 1.0;
    }
    let runs = if n <= RUNS * RUN { 1 } else { RUNS };
    let len = if runs == 1 { n } else { RUN };
    let (mut local, mut total) = (0usize, 0usize);
    for r in 0..runs {
        let start = if runs == 1 {
            0
        } else {
            r * (n - len) / (runs - 1)
        };
        let mut prev: Option<u64> = None;
        for t in &mesh.tets[start..start + len] {
            let lo = t.iter().copied().min().unwrap_or(0) as u64;
            let hi = t.iter().copied().max().unwrap_or(0) as u64;
            if let Some(p) = prev {
                total += 1;
                if hi - lo < WINDOW && lo.abs_diff(p) < WINDOW {
                    local += 1;
                }
            }
            prev = Some(lo);
        }
    }
    if total == 0 {
        1.0
    } else {
        local as f64 / total as f64
    }
}

/// Whether the mesh's numbering is already local: at least
/// [`LOCAL_FRACTION`] of the sampled cells are ([`locality`]).
pub fn is_local(mesh: &TetMesh) -> bool {
    locality(mesh) >= LOCAL_FRACTION
}

/// How [`renumber`] changed a mesh: for each new index, the file's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Renumbering {
    /// `vertices[new] = file index`.
    pub vertices: Vec<u32>,
    /// `cells[new] = file index`.
    pub cells: Vec<u32>,
}

/// Renumbers the mesh along the Morton curve when its numbering is not
/// local ([`is_local`]); returns the sampled locality of the file's
/// numbering ([`locality`]) and the renumbering, `None` when the mesh keeps
/// its order. `pieces` (a `.pvtu`'s tetrahedra per piece, in turn) keeps
/// each piece's cells together: cells move only within their piece.
pub fn make_local(mesh: &mut TetMesh, pieces: Option<&[u64]>) -> (f64, Option<Renumbering>) {
    let l = locality(mesh);
    if l >= LOCAL_FRACTION
        || mesh.tets.len() > u32::MAX as usize
        || mesh.points.len() > u32::MAX as usize
    {
        return (l, None);
    }
    (l, Some(renumber(mesh, pieces)))
}

/// Renumbers vertices by the Morton key of their position and cells by
/// their lowest vertex in the new numbering (within each of `pieces`), and
/// permutes the fields with the vertices. The mesh stays the same set of
/// cells. Keying cells by a vertex index, not by their centroid, reads no
/// position: only the small index map, in cache, and one gather of the cells.
pub fn renumber(mesh: &mut TetMesh, pieces: Option<&[u64]>) -> Renumbering {
    let t = std::time::Instant::now();
    let mut phases = Vec::with_capacity(6);
    let mut lap = |what: &'static str| phases.push((what, t.elapsed().as_secs_f64()));
    let (lo, hi) = mesh.bounds();
    let q = Quantizer::new(lo, hi);
    let mut keys: Vec<u64> = mesh
        .points
        .par_iter()
        .enumerate()
        .map(|(i, p)| (q.key(*p) << 32) | i as u64)
        .collect();
    sort_keys(&mut keys);
    let vertices: Vec<u32> = keys.par_iter().map(|&k| k as u32).collect();
    drop(keys);
    lap("vertex_order");
    let inverse = inverse(&vertices);
    mesh.tets
        .par_iter_mut()
        .for_each(|t| t.iter_mut().for_each(|v| *v = inverse[*v as usize]));
    drop(inverse);
    lap("cell_indices");
    let mut keys: Vec<u64> = mesh
        .tets
        .par_iter()
        .enumerate()
        .map(|(i, t)| (u64::from(t.iter().copied().min().unwrap_or(0)) << 32) | i as u64)
        .collect();
    let whole = [keys.len() as u64];
    let mut rest: &mut [u64] = &mut keys;
    for &len in pieces.unwrap_or(&whole) {
        let (piece, tail) = rest.split_at_mut((len as usize).min(rest.len()));
        sort_keys(piece);
        rest = tail;
    }
    let cells: Vec<u32> = keys.par_iter().map(|&k| k as u32).collect();
    drop(keys);
    lap("cell_order");
    mesh.tets = cells.par_iter().map(|&o| mesh.tets[o as usize]).collect();
    lap("cell_gather");
    gather_vertices(mesh, &vertices);
    lap("vertex_gather");
    tracing::debug!(?phases, "renumbering: seconds since its start");
    Renumbering { vertices, cells }
}

/// `inverse[p[i]] = i`.
fn inverse(p: &[u32]) -> Vec<u32> {
    let mut inv = vec![0u32; p.len()];
    for (new, &old) in p.iter().enumerate() {
        inv[old as usize] = new as u32;
    }
    inv
}

/// New vertex `i` (position and field values) is old vertex `vertices[i]`.
fn gather_vertices(mesh: &mut TetMesh, vertices: &[u32]) {
    mesh.points = vertices
        .par_iter()
        .map(|&o| mesh.points[o as usize])
        .collect();
    for f in &mut mesh.fields {
        let c = f.components.max(1);
        let mut v = vec![0.0; f.values.len()];
        v.par_chunks_mut(c)
            .zip(vertices.par_iter())
            .for_each(|(d, &o)| {
                let o = o as usize * c;
                d.copy_from_slice(&f.values[o..o + c]);
            });
        f.values = v;
    }
}

/// Renumbers `mesh` by `r` (each a permutation of its vertices or cells):
/// new vertex `i` is file vertex `r.vertices[i]`, with its field values;
/// new cell `j` is file cell `r.cells[j]`, its indices renumbered.
pub fn apply(mesh: &mut TetMesh, r: &Renumbering) {
    let inverse = inverse(&r.vertices);
    mesh.tets = r
        .cells
        .par_iter()
        .map(|&o| mesh.tets[o as usize].map(|v| inverse[v as usize]))
        .collect();
    drop(inverse);
    gather_vertices(mesh, &r.vertices);
}

/// A random renumbering of the mesh's vertices and cells, from `seed`:
/// the worst order a file can have, for benchmarks (`pvrsim generate
/// permuted`). The same seed gives the same renumbering.
pub fn permute(mesh: &mut TetMesh, seed: u64) -> Renumbering {
    let r = Renumbering {
        vertices: shuffled(mesh.points.len(), seed),
        cells: shuffled(mesh.tets.len(), seed ^ 0x9e37_79b9_7f4a_7c15),
    };
    apply(mesh, &r);
    r
}

/// `0..n` in a random order (Fisher-Yates, splitmix64 from `seed`).
fn shuffled(n: usize, seed: u64) -> Vec<u32> {
    let mut v: Vec<u32> = (0..n as u32).collect();
    let mut s = seed;
    for i in (1..n).rev() {
        s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        let j = ((u128::from(z) * (i as u128 + 1)) >> 64) as usize;
        v.swap(i, j);
    }
    v
}

/// Positions to 10-bit grid coordinates over a bounding box, and their
/// Morton keys.
pub struct Quantizer {
    lo: [f64; 3],
    scale: [f64; 3],
}

impl Quantizer {
    /// The grid over the box `lo..hi`.
    pub fn new(lo: [f64; 3], hi: [f64; 3]) -> Quantizer {
        let scale = std::array::from_fn(|a| {
            let e = hi[a] - lo[a];
            if e > 0.0 {
                1024.0 / e
            } else {
                0.0
            }
        });
        Quantizer { lo, scale }
    }

    /// The 30-bit Morton key of `p` (x in the lowest bit of each triple).
    pub fn key(&self, p: [f64; 3]) -> u64 {
        let mut k = 0u64;
        for (a, ((x, lo), s)) in p.iter().zip(self.lo).zip(self.scale).enumerate() {
            // `as` saturates (and maps NaN to 0): always 0..=1023.
            let g = (((x - lo) * s) as u32).min(1023);
            k |= spread(g) << a;
        }
        k
    }
}

/// The 10 bits of `x` at every third bit.
fn spread(x: u32) -> u64 {
    let mut x = u64::from(x) & 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    (x | (x << 2)) & 0x0924_9249
}

/// Bits of the most-significant digit (at most bits 54..64) and of the two
/// least-significant ones (bits 32..43, 43..54) of [`sort_keys`].
const TOP: u32 = 10;
const LOW: u32 = 11;

/// Sorts keys whose bits 32..64 hold a curve key (or a vertex index) and
/// bits 0..32 an index, by key then index: a most-significant pass on the
/// highest 10 bits in use (at most bits 54..64) over the whole array, then
/// the buckets in parallel, each by two least-significant passes (bits
/// 32..43, 43..54), which keep the first pass's index order among equal
/// keys. Equal to `v.sort_unstable()` when
/// the values are distinct.
pub fn sort_keys(v: &mut [u64]) {
    if v.len() <= 4096 {
        v.sort_unstable();
        return;
    }
    // The most-significant digit: the highest TOP bits in use (keys of
    // vertex indices leave the high bits 0), the two LOW passes below it
    // (overlapping it when the keys are short, which a bucket's equal
    // digit makes harmless).
    let high = 64 - v.par_iter().copied().max().unwrap_or(0).leading_zeros();
    let top = high.saturating_sub(TOP).clamp(32, 32 + 2 * LOW);
    let buckets = 1usize << TOP;
    let digit = move |x: u64| (x >> top) as usize & (buckets - 1);
    let counts = v
        .par_chunks(1 << 16)
        .map(|c| {
            let mut h = vec![0usize; buckets];
            c.iter().for_each(|&x| h[digit(x)] += 1);
            h
        })
        .reduce(
            || vec![0usize; buckets],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
                a
            },
        );
    let mut next = Vec::with_capacity(buckets);
    let mut acc = 0;
    for &c in &counts {
        next.push(acc);
        acc += c;
    }
    let mut out = vec![0u64; v.len()];
    for &x in v.iter() {
        let b = digit(x);
        out[next[b]] = x;
        next[b] += 1;
    }
    let mut parts = Vec::with_capacity(buckets);
    let mut rest: &mut [u64] = &mut out;
    for &c in &counts {
        let (b, tail) = rest.split_at_mut(c);
        parts.push(b);
        rest = tail;
    }
    parts.into_par_iter().for_each(|b| {
        if b.len() <= 256 {
            b.sort_unstable();
            return;
        }
        let mut tmp = vec![0u64; b.len()];
        counting_pass(b, &mut tmp, 32);
        counting_pass(&tmp, b, 32 + LOW);
    });
    v.copy_from_slice(&out);
}

/// One stable counting-sort pass of `from` into `to` by the [`LOW`]-bit
/// digit at `shift`.
fn counting_pass(from: &[u64], to: &mut [u64], shift: u32) {
    let mask = (1usize << LOW) - 1;
    let digit = |x: u64| (x >> shift) as usize & mask;
    let mut next = vec![0usize; mask + 1];
    from.iter().for_each(|&x| next[digit(x)] += 1);
    let mut acc = 0;
    for n in next.iter_mut() {
        let c = *n;
        *n = acc;
        acc += c;
    }
    for &x in from {
        let d = digit(x);
        to[next[d]] = x;
        next[d] += 1;
    }
}
