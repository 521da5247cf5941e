//! The fuzz targets of `fuzz/` on stable, bounded in time (issue 25): every
//! target body (`fuzz/bodies.rs`, the same functions `cargo fuzz run` drives
//! on nightly) runs over (a) every seed of its corpus `fuzz/corpus/<target>/`
//! and (b) proptest mutations of those seeds (bit flips, byte sets,
//! truncation, splicing, forged little-endian length fields) and random
//! bytes. A body must not panic, and no single allocation may exceed
//! [`ALLOC_CAP`] (the stable stand-in for libFuzzer's `-malloc_limit_mb`).
//!
//! CI: `cargo test --release --test fuzz_decoders` (fixed RNG seed). More:
//! `PROPTEST_RNG_SEED=$RANDOM PROPTEST_CASES=200000 cargo test --release
//! --test fuzz_decoders`.
//! Regenerate the encoded seeds: `cargo test --release --test fuzz_decoders
//! -- --ignored write_seeds` (see `fuzz/README.md`).

#[path = "../fuzz/bodies.rs"]
mod bodies;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

// ---- the allocation cap ---------------------------------------------------

/// Largest single allocation a body may make (bytes) for an input of at
/// most a few KiB: 64 MiB, far above what any seed needs and far below a
/// forged length of 2^32 or more.
const ALLOC_CAP: usize = 64 << 20;

struct Tracking;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|m| {
        if size > m.get() {
            m.set(size);
        }
    });
}

unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        note(l.size());
        System.alloc(l)
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        note(l.size());
        System.alloc_zeroed(l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        note(n);
        System.realloc(p, l, n)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        System.dealloc(p, l)
    }
}

#[global_allocator]
static ALLOC: Tracking = Tracking;

thread_local! {
    /// Inside [`run`]: the panic hook records instead of printing.
    static QUIET: Cell<bool> = const { Cell::new(false) };
    static LAST_PANIC: Cell<Option<String>> = const { Cell::new(None) };
}

/// A panic hook that, inside [`run`], keeps the panic's message and place
/// (shown in the test's failure) instead of printing it for every shrink
/// step; elsewhere it is the default hook.
fn quiet_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.with(|q| q.get()) {
                let msg = info
                    .payload()
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| info.payload().downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                let at = info.location().map(|l| l.to_string()).unwrap_or_default();
                LAST_PANIC.with(|p| p.set(Some(format!("`{msg}` at {at}"))));
            } else {
                default(info)
            }
        }));
    });
}

/// Runs `body` on `data`: a panic or an allocation past [`ALLOC_CAP`] is a
/// failure that shows the input.
fn run(name: &str, body: bodies::Body, data: &[u8]) -> Result<(), String> {
    quiet_hook();
    LARGEST.with(|m| m.set(0));
    QUIET.with(|q| q.set(true));
    let r = std::panic::catch_unwind(|| body(data));
    QUIET.with(|q| q.set(false));
    let largest = LARGEST.with(|m| m.get());
    match r {
        Err(_) => {
            let what = LAST_PANIC.with(|p| p.take()).unwrap_or_default();
            Err(format!(
                "{name}: panic {what} on {} bytes: {}",
                data.len(),
                hex(data)
            ))
        }
        Ok(()) if largest > ALLOC_CAP => Err(format!(
            "{name}: an allocation of {largest} bytes (cap {ALLOC_CAP}) on {} bytes: {}",
            data.len(),
            hex(data)
        )),
        Ok(()) => Ok(()),
    }
}

fn hex(d: &[u8]) -> String {
    let s: String = d.iter().take(512).map(|b| format!("{b:02x}")).collect();
    if d.len() > 512 {
        format!("{s}...")
    } else {
        s
    }
}

// ---- the corpora ----------------------------------------------------------

fn corpus_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target)
}

/// Every file of a target's corpus, sorted by name.
fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = corpus_dir(target);
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    v.sort();
    assert!(v.len() >= 5, "{}: only {} seeds", dir.display(), v.len());
    v
}

fn body(target: &str) -> bodies::Body {
    bodies::TARGETS
        .iter()
        .find(|(n, _)| *n == target)
        .map(|(_, b)| *b)
        .expect("a target")
}

// ---- mutations --------------------------------------------------------------

/// One edit of a seed.
#[derive(Debug, Clone)]
enum Edit {
    /// Flip bit `bit` of byte `at`.
    Flip { at: prop::sample::Index, bit: u8 },
    /// Set byte `at` to `v`.
    Set { at: prop::sample::Index, v: u8 },
    /// Keep the first `at` bytes.
    Truncate { at: prop::sample::Index },
    /// Remove `n` bytes at `at`.
    Remove { at: prop::sample::Index, n: usize },
    /// Insert `bytes` at `at`.
    Insert {
        at: prop::sample::Index,
        bytes: Vec<u8>,
    },
    /// Write a little-endian `u32` or `u64` length at `at` (the codecs'
    /// length prefixes): small, near a limit, or huge.
    Length {
        at: prop::sample::Index,
        wide: bool,
        v: u64,
    },
    /// Replace from `at` on with the tail of another seed from `from`.
    Splice {
        other: prop::sample::Index,
        at: prop::sample::Index,
        from: prop::sample::Index,
    },
}

fn lengths() -> impl Strategy<Value = u64> {
    prop_oneof![
        0u64..64,
        Just((1 << 16) - 1),
        Just(1 << 16),
        Just((1 << 16) + 1),
        Just(u32::MAX as u64),
        Just(1 << 60),
        Just(u64::MAX),
        any::<u64>(),
    ]
}

fn edit() -> impl Strategy<Value = Edit> {
    use prop::sample::Index;
    prop_oneof![
        3 => (any::<Index>(), 0u8..8).prop_map(|(at, bit)| Edit::Flip { at, bit }),
        2 => (any::<Index>(), any::<u8>()).prop_map(|(at, v)| Edit::Set { at, v }),
        1 => any::<Index>().prop_map(|at| Edit::Truncate { at }),
        1 => (any::<Index>(), 1usize..16).prop_map(|(at, n)| Edit::Remove { at, n }),
        1 => (any::<Index>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(at, bytes)| Edit::Insert { at, bytes }),
        2 => (any::<Index>(), any::<bool>(), lengths())
            .prop_map(|(at, wide, v)| Edit::Length { at, wide, v }),
        1 => (any::<Index>(), any::<Index>(), any::<Index>())
            .prop_map(|(other, at, from)| Edit::Splice { other, at, from }),
    ]
}

fn apply(seeds: &[(String, Vec<u8>)], mut d: Vec<u8>, e: &Edit) -> Vec<u8> {
    // An index into 0..=len (the end included).
    let pos = |i: &prop::sample::Index, len: usize| i.index(len + 1);
    match e {
        Edit::Flip { at, bit } if !d.is_empty() => {
            let i = at.index(d.len());
            d[i] ^= 1 << bit;
        }
        Edit::Set { at, v } if !d.is_empty() => {
            let i = at.index(d.len());
            d[i] = *v;
        }
        Edit::Truncate { at } => d.truncate(pos(at, d.len())),
        Edit::Remove { at, n } => {
            let i = pos(at, d.len());
            let j = (i + n).min(d.len());
            d.drain(i..j);
        }
        Edit::Insert { at, bytes } => {
            let i = pos(at, d.len());
            d.splice(i..i, bytes.iter().copied());
        }
        Edit::Length { at, wide, v } => {
            let w = if *wide { 8 } else { 4 };
            if d.len() >= w {
                let i = at.index(d.len() - w + 1);
                let b = v.to_le_bytes();
                d[i..i + w].copy_from_slice(&b[..w]);
            }
        }
        Edit::Splice { other, at, from } => {
            let o = &seeds[other.index(seeds.len())].1;
            let i = pos(at, d.len());
            let j = pos(from, o.len());
            d.truncate(i);
            d.extend_from_slice(&o[j..]);
        }
        _ => {}
    }
    d
}

/// Cases per target and per kind (mutations, random bytes); the default
/// keeps the whole test well under a minute in release mode.
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// A runner of `cases` cases. The RNG seed is fixed (CI runs the same
/// inputs every time; a failure reproduces) unless `PROPTEST_RNG_SEED` is
/// set, e.g. to explore locally.
fn runner(cases: u32) -> TestRunner {
    let mut config = Config {
        cases,
        failure_persistence: None,
        // A failure shrinks, but not for long: the message shows the input.
        max_shrink_iters: 256,
        ..Config::default()
    };
    if std::env::var_os("PROPTEST_RNG_SEED").is_none() {
        config.rng_seed = RngSeed::Fixed(25);
    }
    TestRunner::new(config)
}

fn fuzz_target(target: &str, mutations: u32, random: u32) {
    let body = body(target);
    let seeds = corpus(target);
    for (name, d) in &seeds {
        if let Err(e) = run(target, body, d) {
            panic!("seed {name}: {e}");
        }
    }
    let n = seeds.len();
    let strat = (0..n, prop::collection::vec(edit(), 1..6));
    runner(cases(mutations))
        .run(&strat, |(k, edits)| {
            let d = edits
                .iter()
                .fold(seeds[k].1.clone(), |d, e| apply(&seeds, d, e));
            run(target, body, &d).map_err(TestCaseError::fail)
        })
        .unwrap_or_else(|e| panic!("{target}, mutations: {e}"));
    let strat = prop::collection::vec(any::<u8>(), 0..512);
    runner(cases(random))
        .run(&strat, |d| {
            run(target, body, &d).map_err(TestCaseError::fail)
        })
        .unwrap_or_else(|e| panic!("{target}, random bytes: {e}"));
}

#[test]
fn link_frames() {
    fuzz_target("link_frames", 20_000, 5_000);
}

#[test]
fn phase2_message() {
    fuzz_target("phase2_message", 20_000, 5_000);
}

#[test]
fn readers() {
    fuzz_target("readers", 20_000, 5_000);
}

#[test]
fn session() {
    fuzz_target("session", 20_000, 5_000);
}

// ---- the seeds ----------------------------------------------------------------

mod seeds {
    use std::path::Path;

    use pvrsim::base::segment::Rgba;
    use pvrsim::cluster::remote::phase2::encode_message;
    use pvrsim::cluster::remote::session::{sha256, Session, WorkerSetup};
    use pvrsim::compositor::region::screen;
    use pvrsim::compositor::{codec, strategy, Payload, RegionPixels, RoundKind};
    use pvrsim::data::io::volume::nrrd_write::write_nrrd;
    use pvrsim::data::io::vtk_write;
    use pvrsim::data::mesh::{Field, TetMesh};
    use pvrsim::data::volume::{Volume, Voxels};
    use pvrsim::net::tcp::frame::{encode_frame, TAG_DATA};
    use pvrsim::net::tcp::LinkFrame;
    use pvrsim::net::{Codec, Envelope, Message, MessageKind, NodeId};
    use pvrsim::node::work::WorkCell;
    use pvrsim::node::{CostProfile, NodeOptions, NodePolicy, WorkUnit};

    pub type Seeds = Vec<(&'static str, Vec<u8>)>;

    fn codec() -> Codec {
        Codec::with_limit(super::bodies::LIMIT)
    }

    fn unit() -> WorkUnit {
        WorkUnit {
            vertex_ids: vec![0, 1, 2, 3, 7],
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
            ],
            scalars: vec![0.0, 0.25, 0.5, 0.75, 1.0],
            cells: vec![
                WorkCell {
                    id: 0,
                    v: [0, 1, 2, 3],
                },
                WorkCell {
                    id: 4,
                    v: [1, 2, 3, 4],
                },
            ],
        }
    }

    fn setup() -> WorkerSetup {
        let cells = unit().encode();
        WorkerSetup {
            rank: 1,
            nodes: 2,
            peers: vec!["127.0.0.1:7001".into(), "127.0.0.1:7002".into()],
            scene_toml: "[camera]\n[image]\nwidth = 16\nheight = 16\n".into(),
            depth_range: [0.0, 1.0],
            node: NodeOptions::default().into(),
            share: true,
            dlb: true,
            policy: NodePolicy::default().into(),
            overlap_peers: vec![0],
            profile: CostProfile::default(),
            list_codec: pvrsim::compositor::codec::ListCodecKind::Rle,
            compositor: pvrsim::compositor::strategy::Compositing::BinarySwap,
            max_message_bytes: super::bodies::LIMIT,
            cells_initial: 2,
            cells_sha256: sha256(&cells),
            pieces: Some(pvrsim::cluster::remote::pieces::PieceSource {
                pvtu: "/data/a.pvtu".into(),
                field: "speed".into(),
                range: [0.0, 1.5],
                pieces: vec![pvrsim::cluster::remote::pieces::WirePiece {
                    index: 1,
                    points: 5,
                    vertex_base: 9,
                    cell_base: 12,
                    cells_max: 6,
                    part: 1,
                    of: 2,
                }],
            }),
            recv_timeout_s: 30.0,
            session_id: [7; 16],
        }
    }

    fn session_bytes(s: &Session) -> Vec<u8> {
        codec().encode(s).expect("a seed encodes")
    }

    pub fn session() -> Seeds {
        let setup = session_bytes(&Session::Setup(Box::new(setup())));
        let cells = session_bytes(&Session::Cells(unit().encode()));
        let mut bad_tag = session_bytes(&Session::Go);
        bad_tag[..4].copy_from_slice(&99u32.to_le_bytes());
        // `Cells` announcing 2^60 bytes (bincode: u32 tag, u64 length).
        let mut huge_cells = cells[..12].to_vec();
        huge_cells[4..12].copy_from_slice(&(1u64 << 60).to_le_bytes());
        // The set-up's `peers` announcing 2^40 strings (after rank, nodes).
        let mut huge_peers = setup.clone();
        huge_peers[12..20].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let mut unit_huge = unit().encode();
        unit_huge[..8].copy_from_slice(&u64::MAX.to_le_bytes());
        vec![
            ("empty", vec![]),
            ("setup", setup.clone()),
            ("setup-truncated", setup[..setup.len() / 2].to_vec()),
            ("setup-peers-2e40", huge_peers),
            ("need", session_bytes(&Session::Need(true))),
            ("cells", cells),
            ("cells-len-2e60", huge_cells),
            ("ready", session_bytes(&Session::Ready { remaining: 2 })),
            ("go", session_bytes(&Session::Go)),
            (
                "failed",
                session_bytes(&Session::Failed("bad cells".into())),
            ),
            ("composite", session_bytes(&Session::Composite)),
            ("unknown-variant", bad_tag),
            ("work-unit", unit().encode()),
            ("work-unit-ids-len-max", unit_huge),
        ]
    }

    fn data_frame(kind: MessageKind, payload: Vec<u8>) -> Vec<u8> {
        let env = Envelope {
            from: NodeId(0),
            to: NodeId(1),
            kind,
            payload,
        };
        encode_frame(&codec(), &LinkFrame::Data(env)).expect("a seed encodes")
    }

    pub fn link_frames() -> Seeds {
        let go = data_frame(Session::KIND, session_bytes(&Session::Go));
        let cells = data_frame(
            Session::KIND,
            session_bytes(&Session::Cells(unit().encode())),
        );
        let heartbeat = encode_frame(&codec(), &LinkFrame::Heartbeat).unwrap();
        let goodbye = encode_frame(&codec(), &LinkFrame::Goodbye).unwrap();
        let mut stream = go.clone();
        stream.extend_from_slice(&heartbeat);
        stream.extend_from_slice(&cells);
        stream.extend_from_slice(&goodbye);
        // Header: tag, from u32, to u32, kind u8, len u64 at 10..18.
        let with_len = |n: u64| {
            let mut f = go[..18].to_vec();
            f[10..18].copy_from_slice(&n.to_le_bytes());
            f
        };
        let mut bad_kind = go.clone();
        bad_kind[9] = 0xff;
        vec![
            ("empty", vec![]),
            ("heartbeat", heartbeat),
            ("goodbye", goodbye),
            ("data-go", go.clone()),
            ("data-cells", cells.clone()),
            (
                "data-image",
                data_frame(MessageKind::Image, phase2_pixels()),
            ),
            ("stream", stream),
            ("unknown-tag", vec![3]),
            ("header-truncated", go[..9].to_vec()),
            ("payload-truncated", cells[..cells.len() - 3].to_vec()),
            ("unknown-kind", bad_kind),
            ("len-limit-plus-1", with_len(super::bodies::LIMIT + 1)),
            ("len-2e60", with_len(1 << 60)),
            ("len-max", with_len(u64::MAX)),
            ("tag-only", vec![TAG_DATA]),
        ]
    }

    /// What rank 1 sends the root in the gather round of the schedule the
    /// `phase2_message` body builds, and the round's index.
    fn gather() -> (u32, pvrsim::base::Rect) {
        let s = strategy::from_name("binary-swap")
            .unwrap()
            .schedule(3, screen(16, 16));
        for (i, r) in s.rounds.iter().enumerate() {
            if r.kind == RoundKind::Gather {
                for x in &r.sends {
                    if let (1, Payload::Pixels(rect)) = (x.from, x.what) {
                        return (i as u32, rect);
                    }
                }
            }
        }
        panic!("rank 1 sends no pixels in the gather")
    }

    fn phase2_pixels() -> Vec<u8> {
        let (round, rect) = gather();
        let n = ((rect.x1 - rect.x0) * (rect.y1 - rect.y0)) as usize;
        let px = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    Rgba::default()
                } else {
                    Rgba {
                        rgb: [0.1, 0.2, 0.3],
                        a: 0.5,
                    }
                }
            })
            .collect();
        let mut body = Vec::new();
        codec::from_name("rle")
            .unwrap()
            .encode_pixels(&RegionPixels { rect, px }, &mut body);
        encode_message(round, Payload::Pixels(rect), &body)
    }

    pub fn phase2_message() -> Seeds {
        let (round, rect) = gather();
        let good = phase2_pixels();
        let mut inverted = good.clone();
        inverted[5..9].copy_from_slice(&100u32.to_le_bytes());
        let mut bad_kind = good.clone();
        bad_kind[4] = 7;
        let mut wrong_round = good.clone();
        wrong_round[..4].copy_from_slice(&0u32.to_le_bytes());
        let big = pvrsim::base::Rect {
            x0: 0,
            y0: 0,
            x1: u32::MAX,
            y1: u32::MAX,
        };
        vec![
            ("empty", vec![]),
            ("gather-pixels", good.clone()),
            ("gather-truncated", good[..good.len() - 5].to_vec()),
            ("header-only", good[..21].to_vec()),
            ("header-truncated", good[..20].to_vec()),
            ("inverted-rect", inverted),
            ("unknown-kind", bad_kind),
            ("not-a-gather-round", wrong_round),
            (
                "lists",
                encode_message(round, Payload::Lists(rect), &[0; 8]),
            ),
            (
                "rect-max",
                encode_message(round, Payload::Pixels(big), &good[21..]),
            ),
        ]
    }

    fn mesh() -> TetMesh {
        TetMesh {
            points: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
            ],
            tets: vec![[0, 1, 2, 3], [1, 2, 3, 4]],
            fields: vec![Field {
                name: "speed".into(),
                components: 1,
                values: vec![0.0, 1.0, 2.0, 3.0, 4.0],
            }],
        }
    }

    fn pick(p: u8, file: &[u8]) -> Vec<u8> {
        let mut v = vec![p];
        v.extend_from_slice(file);
        v
    }

    fn nifti() -> Vec<u8> {
        let mut h = vec![0u8; 352];
        h[0..4].copy_from_slice(&348i32.to_le_bytes());
        for (i, v) in [3i16, 2, 2, 2, 1, 1, 1, 1].iter().enumerate() {
            h[40 + 2 * i..42 + 2 * i].copy_from_slice(&v.to_le_bytes());
        }
        h[70..72].copy_from_slice(&2i16.to_le_bytes()); // uint8
        h[72..74].copy_from_slice(&8i16.to_le_bytes()); // bitpix
        for i in 0..8 {
            h[76 + 4 * i..80 + 4 * i].copy_from_slice(&1f32.to_le_bytes());
        }
        h[108..112].copy_from_slice(&352f32.to_le_bytes());
        h[344..348].copy_from_slice(b"n+1\0");
        h.extend_from_slice(&[0, 1, 2, 3, 4, 5, 6, 7]);
        h
    }

    const VTI: &str = r#"<?xml version="1.0"?>
<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt32">
  <ImageData WholeExtent="0 1 0 1 0 1" Origin="0 0 0" Spacing="1 1 1">
  <Piece Extent="0 1 0 1 0 1">
    <PointData Scalars="t1">
      <DataArray type="UInt8" Name="t1" format="ascii">0 1 2 3 4 5 6 7</DataArray>
    </PointData>
  </Piece>
  </ImageData>
</VTKFile>
"#;

    const UCD: &str = "# a two-tet mesh\n5 2 1 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n\
5 1 1 1\n1 1 tet 1 2 3 4\n2 1 tet 2 3 4 5\n1 1\nspeed, m/s\n1 0\n2 1\n3 2\n4 3\n5 4\n";

    const FLD: &[u8] = b"# AVS field file\nndim   = 3\ndim1   = 2\ndim2   = 2\ndim3   = 2\n\
nspace = 3\nveclen = 1\ndata   = byte\nfield  = uniform\n\x0c\x0c\x00\x01\x02\x03\x04\x05\x06\x07";

    fn repo(rel: &str) -> Vec<u8> {
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)).unwrap()
    }

    pub fn readers() -> Seeds {
        let mut ascii = Vec::new();
        vtk_write::write_to(&mesh(), &mut ascii, false).unwrap();
        let mut binary = Vec::new();
        vtk_write::write_to(&mesh(), &mut binary, true).unwrap();
        let v = Volume::new(
            Path::new("seed"),
            [2, 2, 2],
            [1.0, 1.0, 1.0],
            [0.0, 0.0, 0.0],
            "density",
            Voxels::U16((0..8).collect()),
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let nrrd = |gzip: bool| {
            let p = dir.path().join("v.nrrd");
            write_nrrd(&v, &p, gzip, "seed").unwrap();
            std::fs::read(&p).unwrap()
        };
        let mut huge_nrrd = nrrd(false);
        let at = huge_nrrd
            .windows(12)
            .position(|w| w == b"sizes: 2 2 2")
            .expect("the writer's sizes line");
        huge_nrrd.splice(
            at..at + 12,
            b"sizes: 4294967295 65535 65535".iter().copied(),
        );
        let mut nifti_huge = nifti();
        for i in 1..4 {
            nifti_huge[40 + 2 * i..42 + 2 * i].copy_from_slice(&i16::MAX.to_le_bytes());
        }
        vec![
            ("empty", vec![]),
            ("pick-only", vec![0]),
            ("vtk-ascii", pick(0, &ascii)),
            ("vtk-binary", pick(0, &binary)),
            ("vtk-truncated", pick(0, &binary[..binary.len() - 7])),
            ("vtu-ascii", pick(1, &repo("tests/data/vtu/ascii.vtu"))),
            (
                "vtu-binary-zlib",
                pick(1, &repo("tests/data/vtu/binary-zlib.vtu")),
            ),
            (
                "vtu-appended-raw",
                pick(1, &repo("tests/data/vtu/appended-raw.vtu")),
            ),
            ("ucd", pick(2, UCD.as_bytes())),
            ("nrrd", pick(3, &nrrd(false))),
            ("nrrd-gzip", pick(3, &nrrd(true))),
            ("nrrd-sizes-huge", pick(3, &huge_nrrd)),
            ("nifti", pick(4, &nifti())),
            ("nifti-dims-huge", pick(4, &nifti_huge)),
            ("vti-ascii", pick(5, VTI.as_bytes())),
            ("fld", pick(6, FLD)),
            ("fld-truncated", pick(6, &FLD[..FLD.len() - 3])),
        ]
    }

    pub fn all() -> Vec<(&'static str, Seeds)> {
        vec![
            ("link_frames", link_frames()),
            ("phase2_message", phase2_message()),
            ("readers", readers()),
            ("session", session()),
        ]
    }
}

/// Inputs that made a body fail and are not fixed yet, kept in
/// `fuzz/artifacts/<target>/` (where cargo-fuzz writes its crashes). Once
/// the code is fixed, move the file into `fuzz/corpus/<target>/` (a
/// regression seed the other tests run) and this test has nothing left.
#[test]
#[ignore = "fuzz/artifacts/ holds inputs that still fail (see fuzz/README.md)"]
fn known_failures() {
    let mut failed = Vec::new();
    for (target, body) in bodies::TARGETS {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/artifacts")
            .join(target);
        let Ok(files) = std::fs::read_dir(&dir) else {
            continue;
        };
        for f in files {
            let p = f.unwrap().path();
            if let Err(e) = run(target, body, &std::fs::read(&p).unwrap()) {
                failed.push(format!("{}: {e}", p.display()));
            }
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// Writes the generated seeds into `fuzz/corpus/<target>/` (overwriting
/// files of the same name; other files, e.g. inputs cargo-fuzz found, are
/// kept).
#[test]
#[ignore = "writes fuzz/corpus/: run by hand to regenerate the seeds"]
fn write_seeds() {
    for (target, seeds) in seeds::all() {
        let dir = corpus_dir(target);
        std::fs::create_dir_all(&dir).unwrap();
        for (name, bytes) in seeds {
            std::fs::write(dir.join(name), bytes).unwrap();
        }
    }
}

/// The seeds in the repository are the ones the generator writes (run
/// `write_seeds` after changing an encoder or the generator).
#[test]
fn stored_seeds_are_current() {
    for (target, seeds) in seeds::all() {
        for (name, bytes) in seeds {
            let p = corpus_dir(target).join(name);
            let stored = std::fs::read(&p)
                .unwrap_or_else(|e| panic!("{}: {e} (run write_seeds)", p.display()));
            assert!(
                stored == bytes,
                "{} is stale (run write_seeds)",
                p.display()
            );
        }
    }
}

/// The seeds encoded from real values decode, so the mutations start from
/// inputs that reach past the first check.
#[test]
fn valid_seeds_decode() {
    use pvrsim::cluster::remote::phase2::Gather;
    use pvrsim::cluster::remote::session::Session;
    use pvrsim::compositor::region::screen;
    use pvrsim::compositor::{codec, strategy, ExecOptions};
    use pvrsim::data::io::{avs_ucd, volume, vtk_legacy, vtu};
    use pvrsim::net::tcp::decode_all;
    use pvrsim::net::Codec;
    use pvrsim::node::WorkUnit;

    let all = seeds::all();
    let get = |t: &str, n: &str| {
        let (_, s) = all.iter().find(|(x, _)| *x == t).unwrap();
        s.iter().find(|(x, _)| *x == n).unwrap().1.clone()
    };
    let c = Codec::with_limit(bodies::LIMIT);
    for (n, frames) in [
        ("heartbeat", 1),
        ("goodbye", 1),
        ("data-go", 1),
        ("data-cells", 1),
        ("data-image", 1),
        ("stream", 4),
    ] {
        let (f, e) = decode_all(&get("link_frames", n), &c);
        assert!(e.is_none() && f.len() == frames, "link_frames/{n}: {e:?}");
    }
    let s = strategy::from_name("binary-swap")
        .unwrap()
        .schedule(3, screen(16, 16));
    let lc = codec::from_name("rle").unwrap();
    let mut g = Gather::new(&s, lc.as_ref(), ExecOptions::default());
    g.take(1, &get("phase2_message", "gather-pixels"))
        .expect("phase2_message/gather-pixels");
    let p = Path::new("seed");
    for n in [
        "vtk-ascii",
        "vtk-binary",
        "vtu-ascii",
        "vtu-binary-zlib",
        "vtu-appended-raw",
        "ucd",
    ] {
        let d = get("readers", n);
        let r = match d[0] {
            0 => vtk_legacy::parse(&d[1..], p),
            1 => vtu::parse(&d[1..], p),
            _ => avs_ucd::parse(std::str::from_utf8(&d[1..]).unwrap(), p),
        };
        r.unwrap_or_else(|e| panic!("readers/{n}: {e}"));
    }
    for n in ["nrrd", "nrrd-gzip", "nifti", "vti-ascii", "fld"] {
        let d = get("readers", n);
        let r = match d[0] {
            3 => volume::nrrd::parse(&d[1..], p, ""),
            4 => volume::nifti::parse(&d[1..], p, ""),
            5 => volume::vti::parse(&d[1..], p, ""),
            _ => volume::avs_field::parse(&d[1..], p, ""),
        };
        r.unwrap_or_else(|e| panic!("readers/{n}: {e}"));
    }
    match c.decode::<Session>(&get("session", "setup")) {
        Ok(Session::Setup(s)) => s.validate().expect("session/setup validates"),
        other => panic!("session/setup: {other:?}"),
    }
    for n in ["need", "cells", "ready", "go", "failed", "composite"] {
        c.decode::<Session>(&get("session", n))
            .unwrap_or_else(|e| panic!("session/{n}: {e}"));
    }
    WorkUnit::decode(&get("session", "work-unit")).expect("session/work-unit");
}

/// The harness itself: a panic and an allocation past the cap are failures
/// that name the input.
#[test]
fn harness_catches_panics_and_large_allocations() {
    fn panics(d: &[u8]) {
        assert!(d.is_empty(), "not empty");
    }
    fn allocates(d: &[u8]) {
        let v: Vec<u8> = Vec::with_capacity(ALLOC_CAP + d.len() + 1);
        std::hint::black_box(&v);
    }
    assert!(run("p", panics, &[]).is_ok());
    let e = run("p", panics, &[0xab]).unwrap_err();
    assert!(
        e.contains("not empty") && e.contains("on 1 bytes: ab"),
        "{e}"
    );
    let e = run("a", allocates, &[]).unwrap_err();
    assert!(e.contains("an allocation of"), "{e}");
}
