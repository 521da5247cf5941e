//! The compositor against the sequential renderer on a real render.
//!
//! The cells of `aorta-small` are spread over `n` nodes (contiguous blocks of
//! cell ids — "where the simulation produced them" — and, to stress merging,
//! a scattered assignment); each node scan-converts only its cells with the
//! renderer's own `scan_tile`; the compositor merges and composites. The
//! image must equal the sequential render in canonical form bit for bit, for
//! every node count, strategy, codec and partial-composition setting.
//!
//! Run with `--nocapture` for the byte table and the measured difference
//! between canonical and insertion-order composition.

use std::path::Path;

use pvrsim::base::Segment;
use pvrsim::compositor::canonical;
use pvrsim::compositor::codec::{self, Codec};
use pvrsim::compositor::region::screen;
use pvrsim::compositor::strategy::{self, Strategy};
use pvrsim::compositor::{run_local, ExecOptions, LocalRun, RegionLists};
use pvrsim::image::Image;
use pvrsim::render::cell::list::{composite as legacy_composite, insert_sorted};
use pvrsim::render::cell::{
    self, bin, project, scan_tile, CellOptions, CellOrder, ErtOptions, PreparedTf,
};

/// The renderer's defaults with early ray termination off: these tests
/// compare exact compositions, which ERT would change within its bound.
fn no_ert() -> CellOptions {
    CellOptions {
        ert: ErtOptions::OFF,
        ..CellOptions::default()
    }
}
use pvrsim::render::RenderInput;

fn load(scene: &str) -> RenderInput {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(scene);
    RenderInput::load(&path).unwrap_or_else(|e| panic!("{e}")).0
}

/// Per node, per pixel of the whole image: the segments of the node's cells,
/// scanned in the renderer's front-to-back cell order (insertion-order merges
/// with `partial`, raw segments without).
fn node_lists(
    input: &RenderInput,
    nodes: usize,
    owner: &dyn Fn(u32) -> usize,
    partial: bool,
) -> Vec<Vec<Vec<Segment>>> {
    let view = input.scene.view();
    let tf = PreparedTf::new(&input.scene.transfer);
    let pv = project::ProjectedVertices::new(&view, &input.mesh.points, &input.s_norm);
    let opts = CellOptions {
        partial_composition: partial,
        ..no_ert()
    };
    let binning = bin::bin_cells(
        &input.mesh.tets,
        &pv,
        &tf,
        opts.tile_size,
        CellOrder::FrontToBack,
    );
    let (w, h) = (view.width as usize, view.height as usize);
    let mut out = vec![vec![Vec::new(); w * h]; nodes];
    let mut cells = Vec::new();
    for (t, rect) in binning.tiles.iter().enumerate() {
        binning.records(t, &pv, &mut cells);
        for (node, lists) in out.iter_mut().enumerate() {
            let mine: Vec<_> = cells
                .iter()
                .filter(|c| owner(c.cell) == node)
                .copied()
                .collect();
            if mine.is_empty() {
                continue;
            }
            let t = scan_tile(pv.perspective.then(|| pv.rays()), &tf, &opts, *rect, &mine);
            for (idx, l) in t.lists.lists().iter().enumerate() {
                let (i, j) = (
                    rect.x0 as usize + idx % rect.width() as usize,
                    rect.y0 as usize + idx / rect.width() as usize,
                );
                lists[j * w + i] = l.clone();
            }
        }
    }
    out
}

fn same_bits(a: &Image, b: &Image) -> usize {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| {
            p.iter()
                .zip(q.iter())
                .any(|(x, y)| x.to_bits() != y.to_bits())
        })
        .count()
}

/// The sequential render with canonical final composition: all cells on
/// one node.
fn canonical_reference(input: &RenderInput) -> Image {
    let raw = node_lists(input, 1, &|_| 0, false).pop().unwrap();
    let (w, h) = (input.scene.image.width, input.scene.image.height);
    let bg = input.scene.image.background.map(|c| c as f32);
    Image {
        width: w,
        height: h,
        pixels: raw
            .iter()
            .map(|l| canonical::over_background(canonical::composite(l), bg))
            .collect(),
    }
}

struct Row {
    scene: &'static str,
    nodes: usize,
    strategy: &'static str,
    codec: &'static str,
    partial: bool,
    bytes: u64,
    raw: u64,
    messages: usize,
    rounds: usize,
}

fn check_scene(scene: &'static str, counts: &[usize], rows: &mut Vec<Row>) {
    let input = load(scene);
    let want = canonical_reference(&input);
    let (legacy, _) = cell::render(&input, &no_ert());
    eprintln!(
        "{scene}: canonical vs current renderer (insertion-order merges): {} of {} pixels differ in bits, max-abs {:.2e}/255",
        same_bits(&want, &legacy),
        want.pixels.len(),
        want.error_against_rgba(&legacy).max_abs
    );
    let ncells = input.mesh.tets.len() as u64;
    let (w, h) = (input.scene.image.width, input.scene.image.height);
    let bg = input.scene.image.background.map(|c| c as f32);
    for &n in counts {
        let block = move |c: u32| (c as u64 * n as u64 / ncells) as usize;
        let raw = node_lists(&input, n, &block, false);
        for partial in [true, false] {
            let lists: Vec<RegionLists> = raw
                .iter()
                .map(|l| RegionLists::canonical(screen(w, h), l, partial))
                .collect();
            for (sname, _) in strategy::list() {
                let s: Box<dyn Strategy> = strategy::from_name(sname).unwrap();
                for (cname, _) in codec::list() {
                    let c: Box<dyn Codec> = codec::from_name(cname).unwrap();
                    let opts = ExecOptions {
                        partial,
                        background: bg,
                        ..Default::default()
                    };
                    let (img, st) = run_local(s.as_ref(), c.as_ref(), lists.clone(), opts).unwrap();
                    let diff = same_bits(&img, &want);
                    assert_eq!(diff, 0, "{scene} n={n} {sname} {cname} partial={partial}: {diff} pixels differ (max-abs {:.2e}/255)", img.error_against_rgba(&want).max_abs);
                    if *cname == "rle" && n > 1 {
                        assert!(
                            st.bytes_total < st.bytes_uncompressed,
                            "{sname} n={n}: rle {} >= raw {}",
                            st.bytes_total,
                            st.bytes_uncompressed
                        );
                    }
                    if *cname == "raw" {
                        assert_eq!(st.bytes_total, st.bytes_uncompressed);
                    }
                    rows.push(Row {
                        scene,
                        nodes: n,
                        strategy: s.name(),
                        codec: c.name(),
                        partial,
                        bytes: st.bytes_total,
                        raw: st.bytes_uncompressed,
                        messages: st.messages,
                        rounds: st.rounds.len(),
                    });
                }
            }
        }
    }
}

#[test]
fn distributed_equals_sequential_bit_for_bit() {
    let mut rows = Vec::new();
    check_scene(
        "aorta-small-view-b.toml",
        &[1, 2, 3, 5, 8, 16, 64],
        &mut rows,
    );
    check_scene("aorta-small-view-a.toml", &[3, 8], &mut rows);
    eprintln!(
        "\n{:<26} {:>5} {:<12} {:<5} {:<7} {:>10} {:>10} {:>6} {:>5} {:>6}",
        "scene",
        "nodes",
        "strategy",
        "codec",
        "partial",
        "bytes",
        "raw bytes",
        "ratio",
        "msgs",
        "rounds"
    );
    for r in &rows {
        eprintln!(
            "{:<26} {:>5} {:<12} {:<5} {:<7} {:>10} {:>10} {:>6.3} {:>5} {:>6}",
            r.scene,
            r.nodes,
            r.strategy,
            r.codec,
            r.partial,
            r.bytes,
            r.raw,
            r.bytes as f64 / r.raw as f64,
            r.messages,
            r.rounds
        );
    }
}

#[test]
fn scattered_cells_still_bit_for_bit() {
    // Cells dealt round-robin by a hash: every pixel's chains are cut into
    // pieces held by different nodes, the hardest case for merging.
    let input = load("aorta-small-view-b.toml");
    let want = canonical_reference(&input);
    let (w, h) = (input.scene.image.width, input.scene.image.height);
    for n in [2, 5, 8] {
        let scatter = move |c: u32| (c.wrapping_mul(2_654_435_761) >> 7) as usize % n;
        let raw = node_lists(&input, n, &scatter, false);
        let lists: Vec<RegionLists> = raw
            .iter()
            .map(|l| RegionLists::canonical(screen(w, h), l, true))
            .collect();
        for (sname, _) in strategy::list() {
            let s = strategy::from_name(sname).unwrap();
            let opts = ExecOptions {
                background: input.scene.image.background.map(|c| c as f32),
                ..Default::default()
            };
            let (img, st) = run_local(s.as_ref(), &codec::Rle, lists.clone(), opts).unwrap();
            assert_eq!(same_bits(&img, &want), 0, "{sname} n={n}");
            eprintln!(
                "scattered n={n} {sname}: {} bytes rle, {} raw, {} list merges, {} entries merged",
                st.bytes_total, st.bytes_uncompressed, st.merges, st.segments_merged
            );
        }
    }
}

#[test]
fn insertion_order_merging_differs_only_by_rounding() {
    // Without the canonical form (the renderer's insertion-order merges on
    // every node, then the nodes' lists inserted at the owner), the image
    // depends on the node count in the last bits. Measure how much.
    let input = load("aorta-small-view-b.toml");
    let (seq, _) = cell::render(&input, &no_ert());
    let ncells = input.mesh.tets.len() as u64;
    let bg = input.scene.image.background.map(|c| c as f32);
    let mut worst: f64 = 0.0;
    for n in [2, 3, 5, 8, 16] {
        let block = move |c: u32| (c as u64 * n as u64 / ncells) as usize;
        let per_node = node_lists(&input, n, &block, true);
        let px: Vec<[f32; 4]> = (0..per_node[0].len())
            .map(|p| {
                let mut l = Vec::new();
                for node in &per_node {
                    for s in &node[p] {
                        insert_sorted(&mut l, *s, true);
                    }
                }
                canonical::over_background(legacy_composite(&l), bg)
            })
            .collect();
        let img = Image {
            width: seq.width,
            height: seq.height,
            pixels: px,
        };
        let (d, m) = (same_bits(&img, &seq), img.error_against_rgba(&seq).max_abs);
        eprintln!("insertion-order merging, n={n}: {d} pixels differ in bits from the sequential render, max-abs {m:.2e}/255");
        worst = worst.max(m);
    }
    assert!(
        worst < 1e-3,
        "rounding differences should stay far below 1/255, got {worst}"
    );
}

#[test]
fn memory_cost_of_the_canonical_form() {
    // Partial composition's savings: segments stored without merging, with
    // the renderer's insertion-order merging, and with canonical merging.
    for scene in ["aorta-small-view-b.toml", "aorta-small-view-a.toml"] {
        let input = load(scene);
        let (w, h) = (input.scene.image.width, input.scene.image.height);
        let (_, stats) = cell::render(&input, &no_ert());
        let raw = node_lists(&input, 1, &|_| 0, false).pop().unwrap();
        let generated: usize = raw.iter().map(Vec::len).sum();
        let canon = RegionLists::canonical(screen(w, h), &raw, true);
        let ncells = input.mesh.tets.len() as u64;
        let n = 8;
        let block = move |c: u32| (c as u64 * n as u64 / ncells) as usize;
        let per_node: usize = node_lists(&input, n, &block, false)
            .iter()
            .map(|l| {
                RegionLists::canonical(screen(w, h), l, true)
                    .segments()
                    .len()
            })
            .sum();
        let per_node_legacy: usize = node_lists(&input, n, &block, true)
            .iter()
            .flatten()
            .map(Vec::len)
            .sum();
        eprintln!(
            "{scene}: segments generated {generated}; stored with insertion-order partial composition {}; with canonical partial composition {} (one node), {} (summed over 8 nodes; insertion-order: {})",
            stats.segments_stored,
            canon.segments().len(),
            per_node,
            per_node_legacy
        );
        assert_eq!(stats.segments_generated as usize, generated);
        assert!(canon.segments().len() < generated);
    }
}

#[test]
fn round_by_round_and_tampered_messages() {
    let input = load("aorta-small-view-b.toml");
    let (w, h) = (input.scene.image.width, input.scene.image.height);
    let ncells = input.mesh.tets.len() as u64;
    let n = 5;
    let block = move |c: u32| (c as u64 * n as u64 / ncells) as usize;
    let lists: Vec<RegionLists> = node_lists(&input, n, &block, false)
        .iter()
        .map(|l| RegionLists::canonical(screen(w, h), l, true))
        .collect();
    let bswap = strategy::from_name("binary-swap").unwrap();
    // Round by round, as a simulator would drive it.
    let mut run = LocalRun::new(
        bswap.as_ref(),
        &codec::Rle,
        lists.clone(),
        ExecOptions::default(),
    )
    .unwrap();
    while let Some(round) = run.next_round() {
        let label = round.label.clone();
        let msgs = run.outgoing().unwrap();
        let sizes: Vec<usize> = msgs.iter().map(|m| m.bytes.len()).collect();
        let st = run.deliver(msgs).unwrap();
        eprintln!("binary-swap n={n} rle, round {label:<9}: {:>2} messages, {:>8} bytes (raw {:>8}), sizes {sizes:?}", st.messages, st.bytes, st.bytes_uncompressed);
    }
    assert!(run.finish().is_ok());
    // A corrupted message is an error naming the link, never a panic.
    let mut run =
        LocalRun::new(bswap.as_ref(), &codec::Rle, lists, ExecOptions::default()).unwrap();
    let mut msgs = run.outgoing().unwrap();
    let m = &mut msgs[0];
    let at = m.bytes.len() / 2;
    m.bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    m.bytes.truncate(m.bytes.len() - 3);
    let err = run.deliver(msgs).unwrap_err().to_string();
    assert!(err.starts_with("message 4 -> 0"), "{err}");
}
