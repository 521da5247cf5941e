//! Cells with one pixel centre, scan-converted while they are binned
//! (`render::cell::single`), give every pixel the lists that binning them
//! and scanning them in their tiles gives: bit for bit, with the same
//! counters, over image sizes where most cells are smaller than a pixel and
//! where few are, and over the options that change how lists are built.

use std::path::Path;

use pvrsim::render::cell::{
    bin, project, scan_bin, CellOptions, CellOrder, ErtOptions, Integrator, PreparedTf,
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

fn scan(input: &RenderInput, opts: &CellOptions, one_pixel: bool) -> (Scanned, u64) {
    let view = input.scene.view();
    let tf = PreparedTf::new(&input.scene.transfer);
    let pv = project::ProjectedVertices::new(&view, &input.mesh.points, &input.s_norm);
    let binning = bin::bin_cells_rect(
        &input.mesh.tets,
        &pv,
        &tf,
        opts.tile_size,
        opts.tile_size,
        opts.cell_order,
        one_pixel,
    );
    let mut out = Scanned {
        lists: Vec::new(),
        pairs: binning.pairs(),
        pixels_tested: 0,
        segments_generated: 0,
        segments_merged: 0,
        degenerate: binning.one_pixel_degenerate,
    };
    let mut buf = Vec::new();
    for t in 0..binning.tiles.len() {
        let r = scan_bin(&binning, t, &pv, &tf, opts, &mut buf);
        out.pixels_tested += r.counts.pixels_tested;
        out.segments_generated += r.counts.segments_generated;
        out.segments_merged += r.counts.segments_merged;
        out.degenerate += r.degenerate;
        out.lists.push(
            r.lists
                .lists()
                .iter()
                .map(|l| {
                    l.iter()
                        .map(|s| {
                            [
                                s.z_front.to_bits(),
                                s.z_back.to_bits(),
                                s.rgba.rgb[0].to_bits(),
                                s.rgba.rgb[1].to_bits(),
                                s.rgba.rgb[2].to_bits(),
                                s.rgba.a.to_bits(),
                            ]
                        })
                        .collect()
                })
                .collect(),
        );
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
                let (with, fast_cells) = scan(&input, opts, true);
                let (without, none) = scan(&input, opts, false);
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
