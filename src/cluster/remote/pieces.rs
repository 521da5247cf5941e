//! Partitioned data read where it is used: a scene whose data is a `.pvtu`
//! runs on worker processes or TCP workers with **each worker reading its
//! own pieces** ([`read_units`]); the coordinator reads the `.pvtu` and each
//! piece's vertices for the field's range and the scene's depth range, in
//! one pass ([`PieceSet::open`]), never the cells. The pieces are the initial
//! placement, as the paper's nodes held what the simulation wrote: node `k`
//! gets a contiguous run of pieces ([`PieceSet::parts`]), or with fewer
//! pieces than nodes its part of a split piece
//! ([`crate::node::piece_map`]: every node works); DLB then moves cells
//! with their vertices as with any partitioned data.
//!
//! **Numbering.** A worker numbers piece `i`'s vertices `vertex_base(i) +
//! local` (the pieces' vertex counts summed in the `.pvtu`'s order) and its
//! tetrahedra `cell_base(i) + local`, where the cell bases leave room for
//! the tetrahedra of other cell types (at most [`TETS_PER_CELL`] per cell).
//! Ids only have to be unique: a vertex that two pieces both hold (solvers
//! duplicate the vertices of the boundary between pieces) gets two ids, and
//! scan conversion orients faces by the vertices' positions, not their ids
//! ([`crate::render::cell::setup`]), so the cells that meet across the
//! boundary still agree on the face bit for bit: the image is the one a
//! single process renders from the union of the pieces.
//!
//! Every check of the full reader applies (a missing, truncated or
//! inconsistent piece, out-of-range indices), as the worker sees its
//! pieces; the worker also checks that each piece has the vertices the
//! coordinator saw (the same file under the same path).

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::{Deserialize, Serialize};

use crate::data::io::pvtu::{self, summary::Summary};
use crate::node::piece_map::{self, Share};
use crate::node::renderer::NodeRenderer;
use crate::node::work::{WorkCell, WorkUnit};
use crate::scene::Scene;

/// Most tetrahedra one VTK cell becomes (a hexahedron: 6).
pub const TETS_PER_CELL: u64 = 6;

/// One piece a worker reads, with the ids it gives its vertices and cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct WirePiece {
    /// Its index in the `.pvtu`.
    pub index: u32,
    /// Its vertices as the coordinator counted them.
    pub points: u32,
    /// Id of its first vertex.
    pub vertex_base: u32,
    /// Id of its first tetrahedron.
    pub cell_base: u32,
    /// Most tetrahedra it may hold (`TETS_PER_CELL` x its declared cells).
    pub cells_max: u32,
    /// Which part of the piece the worker keeps (`0..of`).
    pub part: u32,
    /// How many parts the piece is split into (1: the whole piece).
    pub of: u32,
}

/// The pieces a worker reads (in its set-up, instead of cells).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PieceSource {
    /// The `.pvtu`'s absolute path on the coordinator's machine: the same
    /// path must reach the same files on every worker's machine.
    pub pvtu: String,
    /// The field rendered.
    pub field: String,
    /// The range the field is normalised with (the whole mesh's).
    pub range: [f64; 2],
    /// Its pieces, ascending.
    pub pieces: Vec<WirePiece>,
}

/// The coordinator's view of a partitioned mesh: its pieces' summaries and
/// the field's range, no cells.
#[derive(Debug, Clone)]
pub struct PieceSet {
    /// What the coordinator read of each piece.
    pub summary: Summary,
    /// The field rendered.
    pub field: String,
    /// The range the field is normalised with: the scene's, or the
    /// field's min..max over every piece (as [`crate::render::RenderInput`]
    /// takes it).
    pub range: [f64; 2],
    /// Per piece: `(vertex_base, cell_base, cells_max)`.
    bases: Vec<(u32, u32, u32)>,
    /// The depth extent of every vertex for the view the set was opened
    /// with (a frame of that view, or a retry after a loss, reads no
    /// vertex again).
    depths: (crate::scene::View, (f64, f64)),
    /// The `.pvtu`'s absolute path, as the workers are told it (whatever
    /// folder they run in).
    absolute: PathBuf,
    /// The piece map's units for the nodes the set was opened for: the
    /// pieces, or with fewer pieces than nodes their parts.
    units: Vec<Share>,
}

impl PieceSet {
    /// Reads the `.pvtu` of `scene`'s data and its pieces' vertices (once:
    /// the field's range and the depth extent for `scene`'s camera), to
    /// be placed on `nodes` nodes.
    pub fn open(scene: &Scene, nodes: usize) -> anyhow::Result<PieceSet> {
        let path = &scene.data.path;
        let view = scene.view();
        let (summary, extents) =
            pvtu::summary::summarize(path, &scene.data.field, EMPTY, fold_depths(&view))?;
        let range = match scene.data.range {
            Some(r) => r,
            None => summary.scalar_range().unwrap_or([0.0, 1.0]),
        };
        let mut bases = Vec::with_capacity(summary.pieces.len());
        let (mut v, mut c) = (0u64, 0u64);
        for p in &summary.pieces {
            let cells_max = p.cells_declared * TETS_PER_CELL;
            let fits = |x: u64| u32::try_from(x).ok();
            let (Some(vb), Some(cb), Some(cm), Some(_), Some(_)) = (
                fits(v),
                fits(c),
                fits(cells_max),
                fits(v + p.points),
                fits(c + cells_max),
            ) else {
                anyhow::bail!(
                    "{}: the pieces hold more than 2^32 vertices or possible tetrahedra \
                     (piece {}: vertex {v}, cell {c}); pvrsim numbers them in 32 bits",
                    path.display(),
                    p.source
                );
            };
            bases.push((vb, cb, cm));
            v += p.points;
            c += cells_max;
        }
        let absolute = std::fs::canonicalize(path)
            .with_context(|| format!("cannot resolve {}", path.display()))?;
        let units = piece_map::shares(&declared(&summary), nodes);
        Ok(PieceSet {
            summary,
            field: scene.data.field.clone(),
            range,
            bases,
            depths: (view, extents.into_iter().fold(EMPTY, union)),
            absolute,
            units,
        })
    }

    /// The `.pvtu`'s path.
    pub fn path(&self) -> &Path {
        &self.summary.path
    }

    /// The piece map's units ([`crate::node::piece_map`]): unit `u` of a
    /// part in [`PieceSet::parts`] is `units()[u]`.
    pub fn units(&self) -> &[Share] {
        &self.units
    }

    /// Whether a piece is split over several nodes (fewer pieces than
    /// nodes).
    pub fn splits(&self) -> bool {
        self.units.iter().any(|s| s.of > 1)
    }

    /// Units per node: `n` contiguous runs of about equal declared cells
    /// ([`crate::node::placement::piece_runs`] over the units, as a run in
    /// this process places the pieces); one unit a node when pieces are
    /// split.
    pub fn parts(&self, n: usize) -> Vec<Vec<u32>> {
        let w = piece_map::unit_weights(&declared(&self.summary), &self.units);
        crate::node::placement::piece_runs(&w, n)
    }

    /// What a worker holding units `part` is told.
    pub fn source(&self, part: &[u32]) -> PieceSource {
        let mut pieces: Vec<WirePiece> = part
            .iter()
            .map(|&u| {
                let s = self.units[u as usize];
                let i = s.piece;
                let (vertex_base, cell_base, cells_max) = self.bases[i as usize];
                WirePiece {
                    index: i,
                    points: self.summary.pieces[i as usize].points as u32,
                    vertex_base,
                    cell_base,
                    cells_max,
                    part: s.part,
                    of: s.of,
                }
            })
            .collect();
        // A survivor may take a lost worker's part of a piece it shares.
        pieces.sort_by_key(|p| (p.index, p.part));
        PieceSource {
            pvtu: self.absolute.to_string_lossy().into_owned(),
            field: self.field.clone(),
            range: self.range,
            pieces,
        }
    }

    /// The frame's depth range for `scene`'s camera over every piece's
    /// vertices, as [`crate::cluster::phase1::depth_range`] gives it for a
    /// whole mesh: from [`PieceSet::open`]'s pass for its view, else the
    /// vertices read again (a piece per thread).
    pub fn depth_range(&self, scene: &Scene) -> anyhow::Result<[f32; 2]> {
        let view = scene.view();
        let ext = if view == self.depths.0 {
            self.depths.1
        } else {
            pvtu::summary::fold_points(&self.summary, EMPTY, fold_depths(&view))?
                .into_iter()
                .fold(EMPTY, union)
        };
        Ok(crate::cluster::phase1::padded_depths(ext))
    }
}

/// Each piece's declared cells (the piece map's weights).
fn declared(summary: &Summary) -> Vec<u64> {
    summary.pieces.iter().map(|p| p.cells_declared).collect()
}

/// The extent of no depth.
const EMPTY: (f64, f64) = (f64::INFINITY, f64::NEG_INFINITY);

/// The union of two depth extents.
fn union(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0.min(b.0), a.1.max(b.1))
}

/// Folds a chunk of points' depth extent for `view` into an extent.
fn fold_depths(view: &crate::scene::View) -> impl Fn(&mut (f64, f64), &[[f64; 3]]) + Sync + '_ {
    move |acc, p| *acc = union(*acc, crate::cluster::phase1::depth_extent(view, p))
}

/// A worker's cells: reads its pieces of `src` (checked as the full reader
/// checks them) and numbers them as the module docs say, one unit a piece.
/// A session keeps them across its frames; [`add_units`] adds them to a
/// frame's node.
pub fn read_units(src: &PieceSource) -> anyhow::Result<Vec<WorkUnit>> {
    let path = PathBuf::from(&src.pvtu);
    let head = pvtu::read_header(&path)?;
    let mut last: Option<(u32, u32)> = None;
    for wp in &src.pieces {
        anyhow::ensure!(
            last.is_none_or(|l| l < (wp.index, wp.part)),
            "the set-up's pieces are not ascending (piece {} part {})",
            wp.index,
            wp.part
        );
        last = Some((wp.index, wp.part));
        anyhow::ensure!(
            (1..=piece_map::MAX_SPLIT).contains(&wp.of) && wp.part < wp.of,
            "the set-up asks for part {} of {} of piece {} (parts are 0..of, of in 1..={})",
            wp.part,
            wp.of,
            wp.index,
            piece_map::MAX_SPLIT
        );
    }
    let mut units = Vec::with_capacity(src.pieces.len());
    // The parts one worker keeps of a piece, read once.
    for group in src.pieces.chunk_by(|a, b| a.index == b.index) {
        let wp = &group[0];
        anyhow::ensure!(
            group.iter().all(
                |g| (g.points, g.vertex_base, g.cell_base, g.cells_max, g.of)
                    == (wp.points, wp.vertex_base, wp.cell_base, wp.cells_max, wp.of)
            ),
            "the set-up describes piece {} two ways",
            wp.index
        );
        let k = wp.index as usize;
        anyhow::ensure!(
            k < head.pieces.len(),
            "{}: piece {k} was asked for, the file names {}",
            path.display(),
            head.pieces.len()
        );
        // An untrusted set-up's ids must not wrap (checked before reading,
        // against the counts it declares; the piece is then held to them).
        let end = |base: u32, n: u32| base as u64 + n as u64 <= 1 << 32;
        anyhow::ensure!(
            end(wp.vertex_base, wp.points) && end(wp.cell_base, wp.cells_max),
            "the set-up numbers piece {k}'s vertices or cells past 2^32"
        );
        let mesh = pvtu::read_piece_keeping(&path, &head, k, Some(&src.field))?;
        let src_name = &head.pieces[k].0;
        let at = || format!("{}: <Piece> {k} Source=\"{src_name}\"", path.display());
        anyhow::ensure!(
            mesh.points.len() as u64 == wp.points as u64,
            "{}: <Piece> {k} Source=\"{src_name}\" has {} vertices here, the coordinator read {} \
             (does this worker see another file under the same path?)",
            path.display(),
            mesh.points.len(),
            wp.points
        );
        anyhow::ensure!(
            mesh.tets.len() as u64 <= wp.cells_max as u64,
            "{}: <Piece> {k} Source=\"{src_name}\" has {} tetrahedra, more than its {} declared \
             cells can make",
            path.display(),
            mesh.tets.len(),
            wp.cells_max as u64 / TETS_PER_CELL
        );
        let raw = mesh.scalar(&src.field).with_context(at)?;
        // As RenderInput normalises (f64), then the node's f32.
        let scalars: Vec<f32> = raw
            .iter()
            .map(|&x| crate::render::input::normalised(x, src.range) as f32)
            .collect();
        drop(raw);
        if let Some(v) = scalars.iter().position(|x| !x.is_finite()) {
            anyhow::bail!(
                "{}: vertex {v}'s scalar is not finite on the range {:?}",
                at(),
                src.range
            );
        }
        let crate::data::TetMesh { points, tets, .. } = mesh;
        if wp.of == 1 {
            // Ascending and unique by construction, as a unit's are; the
            // reader checked every index against the piece's vertices.
            let ids: Vec<u32> = (0..wp.points).map(|v| wp.vertex_base + v).collect();
            let cells = tets
                .iter()
                .enumerate()
                .map(|(c, t)| WorkCell {
                    id: wp.cell_base + c as u32,
                    v: *t,
                })
                .collect();
            units.push(WorkUnit {
                vertex_ids: ids,
                positions: points,
                scalars,
                cells,
            });
            continue;
        }
        let centroids: Vec<[f64; 3]> = tets
            .iter()
            .map(|t| crate::node::placement::centroid(&points, t))
            .collect();
        let parts = piece_map::split(&centroids, wp.of);
        drop(centroids);
        for g in group {
            units.push(part_unit(
                wp,
                &parts[g.part as usize],
                &points,
                &scalars,
                &tets,
            ));
        }
    }
    Ok(units)
}

/// The unit of a split piece's cells `keep` (local, ascending): the
/// vertices they use (ids `vertex_base + local`, ascending) and the cells
/// (ids `cell_base + local`) on them.
fn part_unit(
    wp: &WirePiece,
    keep: &[u32],
    points: &[[f64; 3]],
    scalars: &[f32],
    tets: &[[u32; 4]],
) -> WorkUnit {
    const NONE: u32 = u32::MAX;
    let mut new = vec![NONE; points.len()];
    for &c in keep {
        for &v in &tets[c as usize] {
            new[v as usize] = 0;
        }
    }
    let (mut ids, mut positions, mut kept) = (Vec::new(), Vec::new(), Vec::new());
    for (v, slot) in new.iter_mut().enumerate() {
        if *slot != NONE {
            *slot = ids.len() as u32;
            ids.push(wp.vertex_base + v as u32);
            positions.push(points[v]);
            kept.push(scalars[v]);
        }
    }
    let cells = keep
        .iter()
        .map(|&c| WorkCell {
            id: wp.cell_base + c,
            v: tets[c as usize].map(|v| new[v as usize]),
        })
        .collect();
    WorkUnit {
        vertex_ids: ids,
        positions,
        scalars: kept,
        cells,
    }
}

/// Adds units read by [`read_units`] (or decoded and validated once) to a
/// frame's node ([`NodeRenderer::add_cells`]: the reader or the validation
/// vouched for them). Returns the tetrahedra added.
pub fn add_units(units: &[WorkUnit], node: &mut NodeRenderer) -> u64 {
    let mut cells = 0u64;
    for u in units {
        node.add_cells(
            &u.vertex_ids,
            std::borrow::Cow::Borrowed(&u.positions),
            &u.scalars,
            u.cells.iter().copied(),
        );
        cells += u.cells.len() as u64;
    }
    cells
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A set-up from a hostile or broken coordinator: ids that would wrap,
    /// pieces out of order or not in the file are errors, not panics.
    #[test]
    fn a_bad_set_up_is_an_error() {
        let pvtu = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/pieces/aorta-small-raw.pvtu"
        );
        let head = pvtu::read_header(Path::new(pvtu)).unwrap();
        let points = pvtu::read_piece(Path::new(pvtu), &head, 0)
            .unwrap()
            .points
            .len() as u32;
        let piece = |index, vertex_base| WirePiece {
            index,
            points,
            vertex_base,
            cell_base: 0,
            cells_max: 6 * 6000,
            part: 0,
            of: 1,
        };
        let src = |pieces| PieceSource {
            pvtu: pvtu.into(),
            field: "speed".into(),
            range: [0.0, 1.0],
            pieces,
        };
        let load = |src: &PieceSource| {
            // Looking along +y at the whole mesh (x -46..41, z -200..133).
            let scene = crate::scene::Scene::parse(
                r#"
[data]
path = "aorta-small-raw.pvtu"
field = "speed"
[camera]
eye = [0.0, -300.0, -30.0]
target = [0.0, 0.0, -30.0]
up = [1.0, 0.0, 0.0]
projection = "orthographic"
height = 120.0
[image]
width = 200
height = 64
background = [0.0, 0.0, 0.0]
[transfer]
unit_distance = 1.0
points = [[0.0, 0.0, 0.0, 1.0, 0.3], [1.0, 1.0, 0.0, 0.0, 0.3]]
"#,
                Path::new("s.toml"),
            )
            .unwrap();
            let mut node = NodeRenderer::new(
                scene.view(),
                crate::render::cell::PreparedTf::new(&scene.transfer),
                Default::default(),
            );
            read_units(src).map(|u| (add_units(&u, &mut node), node.remaining()))
        };
        let (n, kept) = load(&src(vec![piece(0, 0)])).unwrap();
        assert!(n > 0 && kept > 0 && kept as u64 <= n, "{n} {kept}");
        let e = load(&src(vec![piece(0, u32::MAX - 3)])).unwrap_err();
        assert!(format!("{e:#}").contains("past 2^32"), "{e:#}");
        let e = load(&src(vec![piece(0, 0), piece(0, 0)])).unwrap_err();
        assert!(format!("{e:#}").contains("not ascending"), "{e:#}");
        let e = load(&src(vec![piece(9, 0)])).unwrap_err();
        assert!(format!("{e:#}").contains("piece 9 was asked for"), "{e:#}");
        // Parts of a split piece: in range, one description per piece, and
        // the two halves together are the whole piece.
        let part = |part, of| WirePiece {
            part,
            of,
            ..piece(0, 0)
        };
        let e = load(&src(vec![part(2, 2)])).unwrap_err();
        assert!(format!("{e:#}").contains("part 2 of 2"), "{e:#}");
        let e = load(&src(vec![part(0, 0)])).unwrap_err();
        assert!(format!("{e:#}").contains("part 0 of 0"), "{e:#}");
        let e = load(&src(vec![part(0, 2), part(1, 3)])).unwrap_err();
        assert!(format!("{e:#}").contains("two ways"), "{e:#}");
        let (a, _) = load(&src(vec![part(0, 2)])).unwrap();
        let (b, _) = load(&src(vec![part(1, 2)])).unwrap();
        let (both, _) = load(&src(vec![part(0, 2), part(1, 2)])).unwrap();
        assert!(
            a > 0 && b > 0 && a + b == n && both == n,
            "{a} {b} {both} {n}"
        );
    }
}
