//! Cells with one pixel centre, scan-converted while they are binned
//! (`render::cell::single`), give every pixel the lists that binning them
//! and scanning them in their tiles gives: bit for bit, with the same
//! counters, over image sizes where most cells are smaller than a pixel and
//! where few are, and over the options that change how lists are built.

use std::path::Path;

use pvrsim::base::Segment;
use pvrsim::render::cell::single::OnePixelMode;
use pvrsim::render::cell::{
    bin, ert, project, scan_bin, CellOptions, CellOrder, ErtOptions, ErtSpan, ErtStructure,
    Integrator, PreparedTf, TileResult,
};
use pvrsim::render::RenderInput;

fn load(scene: &str) -> RenderInput {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(scene);
    RenderInput::load(&path).unwrap_or_else(|e| panic!("{e}")).0
}

/// What a frame's scan produced, by tile and pixel, as bits.
#[derive(Debug, PartialEq)]
struct Scanned {
    lists: Vec<Vec<Vec<[u32; 6]>>>,
    pairs: u64,
    pixels_tested: u64,
    segments_generated: u64,
    segments_merged: u64,
    degenerate: u64,
}

impl Scanned {
    /// Nothing scanned yet of `binning`'s frame: its pairs and the flat
    /// one-pixel cells the binning counted.
    fn new(binning: &bin::Binning) -> Scanned {
        Scanned {
            lists: Vec::new(),
            pairs: binning.pairs(),
            pixels_tested: 0,
            segments_generated: 0,
            segments_merged: 0,
            degenerate: binning.one_pixel_degenerate,
        }
    }

    /// Adds a tile's lists and counters.
    fn add(&mut self, r: &TileResult) {
        self.pixels_tested += r.counts.pixels_tested;
        self.segments_generated += r.counts.segments_generated;
        self.segments_merged += r.counts.segments_merged;
        self.degenerate += r.degenerate;
        self.lists.push(
            r.lists
                .lists()
                .iter()
                .map(|l| l.iter().map(Segment::bits).collect())
                .collect(),
        );
    }
}

/// The frame's transfer function, projected vertices and binning into
/// `tile` tiles, with the one-pixel path in `one_pixel`.
fn binned(
    input: &RenderInput,
    opts: &CellOptions,
    tile: (u32, u32),
    one_pixel: OnePixelMode,
) -> (PreparedTf, project::ProjectedVertices, bin::Binning) {
    let view = input.scene.view();
    let tf = PreparedTf::new(&input.scene.transfer);
    let pv = project::ProjectedVertices::new(&view, &input.mesh.points, &input.s_norm);
    let binning = bin::bin_cells_rect(
        &input.mesh.tets,
        &pv,
        &tf,
        tile.0,
        tile.1,
        opts.cell_order,
        one_pixel,
    );
    (tf, pv, binning)
}

fn scan(input: &RenderInput, opts: &CellOptions, one_pixel: OnePixelMode) -> (Scanned, u64) {
    let (tf, pv, binning) = binned(input, opts, (opts.tile_size, opts.tile_size), one_pixel);
    let mut out = Scanned::new(&binning);
    let mut buf = Vec::new();
    for t in 0..binning.tiles.len() {
        out.add(&scan_bin(&binning, t, &pv, &tf, opts, &mut buf));
    }
    (out, binning.one_pixel_cells)
}

#[test]
fn one_pixel_segments_equal_scanned_cells() {
    let base = CellOptions {
        ert: ErtOptions::OFF,
        ..CellOptions::default()
    };
    let variants = [
        base,
        CellOptions {
            partial_composition: false,
            ..base
        },
        CellOptions {
            canonical: true,
            ..base
        },
        CellOptions {
            cell_order: CellOrder::Stored,
            ..base
        },
        CellOptions {
            integrator: Integrator::Midpoint,
            tile_size: 7,
            ..base
        },
    ];
    for scene in ["aorta-small-view-a.toml", "aorta-small-view-b.toml"] {
        for (w, h) in [(40, 30), (96, 80), (300, 300)] {
            let input = load(scene).with_size(w, h);
            for opts in &variants {
                let (with, fast_cells) = scan(&input, opts, OnePixelMode::Hits);
                let (without, none) = scan(&input, opts, OnePixelMode::Binned);
                assert_eq!(none, 0);
                // The smallest image makes most cells one-pixel ones.
                if (w, h) == (40, 30) {
                    assert!(
                        fast_cells > 1000,
                        "{scene} {w}x{h}: only {fast_cells} one-pixel cells"
                    );
                }
                assert!(with.segments_generated > 0);
                assert!(
                    with == without,
                    "{scene} {w}x{h} {opts:?}: one-pixel segments change the lists or counts"
                );
            }
        }
    }
}

/// What an ERT scan of a frame produced: lists, counters and ERT's own counts.
#[derive(Debug, PartialEq)]
struct ErtScanned {
    scanned: Scanned,
    updates: u64,
    tests: u64,
    skipped_whole: u64,
    skipped_spanning: Vec<(u32, u32)>,
}

fn scan_ert(input: &RenderInput, opts: &CellOptions, one_pixel: OnePixelMode) -> (ErtScanned, u64) {
    let view = input.scene.view();
    let dims = opts.ert.tile_dims(opts.tile_size, view.width, view.height);
    let entry = opts.ert.entry_px(view.width, view.height);
    let (tf, pv, binning) = binned(input, opts, dims, one_pixel);
    let mut out = ErtScanned {
        scanned: Scanned::new(&binning),
        updates: 0,
        tests: 0,
        skipped_whole: 0,
        skipped_spanning: Vec::new(),
    };
    let mut buf = Vec::new();
    for t in 0..binning.tiles.len() {
        let cells = bin::BinCells::new(&binning, t, &pv, &mut buf);
        let (r, e) = ert::scan_tile_ert(
            None,
            &tf,
            opts,
            binning.tiles[t],
            cells,
            binning.segs(t),
            entry,
            dims,
        );
        out.scanned.add(&r);
        out.updates += e.updates;
        out.tests += e.tests;
        out.skipped_whole += e.skipped_whole;
        out.skipped_spanning.extend(e.skipped_spanning);
    }
    (out, binning.one_pixel_cells)
}

/// With early ray termination the binning keeps every one-pixel cell (misses
/// and flat ones marked), so ERT rebuilds, tests and skips exactly where it
/// did with every cell binned: the same lists, counters and ERT counts.
#[test]
fn one_pixel_segments_keep_ert_bit_for_bit() {
    let ert = |threshold, structure, span| ErtOptions {
        mode: pvrsim::render::cell::ert::ErtMode::of_threshold(threshold),
        structure,
        span,
        update_c: 7,
        ..ErtOptions::DEFAULT
    };
    let variants = [
        ert(0.9, ErtStructure::Pyramid, ErtSpan::Multi),
        ert(0.5, ErtStructure::Flat, ErtSpan::Single),
        ert(0.7, ErtStructure::Flat, ErtSpan::Multi),
    ];
    for scene in ["aorta-small-view-a.toml", "aorta-small-view-b.toml"] {
        for (w, h) in [(40, 30), (120, 100)] {
            // Flat cells mixed in (every 40th tetrahedron again with its
            // first vertex twice): ERT counts them, and scans them as
            // degenerate where it does not skip them.
            let plain = load(scene).with_size(w, h);
            let mut mesh = (*plain.mesh).clone();
            let flat: Vec<[u32; 4]> = mesh
                .tets
                .iter()
                .step_by(40)
                .map(|t| [t[0], t[1], t[2], t[0]])
                .collect();
            mesh.tets.extend(flat);
            let input = RenderInput::new(plain.scene.clone(), std::sync::Arc::new(mesh))
                .expect("the same field");
            for e in variants {
                for cell_order in [CellOrder::FrontToBack, CellOrder::Stored] {
                    let opts = CellOptions {
                        ert: e,
                        cell_order,
                        ..CellOptions::default()
                    };
                    let (with, fast_cells) = scan_ert(&input, &opts, OnePixelMode::All);
                    let (without, _) = scan_ert(&input, &opts, OnePixelMode::Binned);
                    if (w, h) == (40, 30) {
                        assert!(fast_cells > 1000, "{scene}: {fast_cells} one-pixel cells");
                        assert!(with.skipped_whole > 0, "{scene} {e:?}: ERT skipped nothing");
                        assert!(with.scanned.degenerate > 0, "{scene}: no flat cell scanned");
                    }
                    assert!(
                        with == without,
                        "{scene} {w}x{h} {e:?} {cell_order:?}: one-pixel segments change ERT"
                    );
                }
            }
        }
    }
}
