//! Wire forms of a grid worker's set-up (sort-last rendering of bricks over
//! `--transport processes|tcp`, see [`super::grid`]): the frame's options,
//! the bricks' places, and the bricks' samples as bytes (the content the
//! worker caches by SHA-256, as cell workers cache their cells).
//!
//! Brick bytes, per brick, little-endian:
//!
//! ```text
//! u64 dims[3] · f64 spacing[3] · f64 origin[3] · u8 type (0 u8, 1 u16, 2 i16, 3 f32) · samples
//! ```
//!
//! preceded by a `u32` brick count. The decoder checks sizes before it
//! allocates and builds each volume with [`Volume::new`] (finite spacing,
//! origin and float samples), so bad bytes are an error, never a panic.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::cluster::remote::phase2::RankLog;
use crate::data::{Volume, Voxels};
use crate::node::grid::{Brick, GridNodeStats};
use crate::render::slice3d::planes::{Planes, SliceCount};
use crate::render::slice3d::Slice3dOptions;
use crate::render::slicing::{Classify, Order};

/// The slicer's options ([`Slice3dOptions`] without the brick frame, which
/// each brick gets from its place).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireSlice {
    /// 0 post, 1 pre, 2 pre-integrated.
    pub classify: u8,
    /// 0 front to back, 1 back to front.
    pub order: u8,
    /// ERT threshold.
    pub ert: f32,
    /// 0 default, 1 count, 2 spacing.
    pub slices_kind: u8,
    /// The count (kind 1).
    pub slices_count: u64,
    /// The spacing (kind 2).
    pub slices_spacing: f64,
    /// Empty-space skipping.
    pub empty_skip: bool,
}

impl From<&Slice3dOptions> for WireSlice {
    fn from(o: &Slice3dOptions) -> Self {
        let (slices_kind, slices_count, slices_spacing) = match o.slices {
            SliceCount::Default => (0, 0, 0.0),
            SliceCount::Count(n) => (1, n, 0.0),
            SliceCount::Spacing(d) => (2, 0, d),
        };
        WireSlice {
            classify: match o.classify {
                Classify::Post => 0,
                Classify::Pre => 1,
                Classify::Preint => 2,
            },
            order: match o.order {
                Order::FrontToBack => 0,
                Order::BackToFront => 1,
            },
            ert: o.ert,
            slices_kind,
            slices_count,
            slices_spacing,
            empty_skip: o.empty_skip,
        }
    }
}

impl WireSlice {
    /// The options, or what is wrong with them.
    pub fn options(&self) -> Result<Slice3dOptions, String> {
        Ok(Slice3dOptions {
            classify: match self.classify {
                0 => Classify::Post,
                1 => Classify::Pre,
                2 => Classify::Preint,
                c => return Err(format!("classification tag {c}")),
            },
            order: match self.order {
                0 => Order::FrontToBack,
                1 => Order::BackToFront,
                o => return Err(format!("order tag {o}")),
            },
            ert: self.ert,
            slices: match self.slices_kind {
                0 => SliceCount::Default,
                1 => SliceCount::Count(self.slices_count),
                2 => SliceCount::Spacing(self.slices_spacing),
                k => return Err(format!("slice count tag {k}")),
            },
            empty_skip: self.empty_skip,
            brick: None,
        })
    }
}

/// A brick's place and visibility rank.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct WireBrick {
    /// Brick id.
    pub id: u32,
    /// Position in the brick grid.
    pub idx: [u32; 3],
    /// First sample (index of the whole).
    pub lo: [u64; 3],
    /// Samples per axis.
    pub dims: [u64; 3],
    /// Visibility rank (0 nearest the eye).
    pub rank: u32,
}

impl WireBrick {
    /// The wire form of `b` with visibility rank `rank`.
    pub fn new(b: &Brick, rank: u32) -> Self {
        WireBrick {
            id: b.id,
            idx: b.idx,
            lo: b.lo,
            dims: b.dims,
            rank,
        }
    }

    /// The brick.
    pub fn brick(&self) -> Brick {
        Brick {
            id: self.id,
            idx: self.idx,
            lo: self.lo,
            dims: self.dims,
        }
    }
}

/// Everything a grid worker needs for a frame, except the bricks' samples.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GridSetup {
    /// This worker's rank among the rendering nodes (the report's rank is
    /// one more with a master).
    pub rank: u32,
    /// Rendering nodes.
    pub nodes: u32,
    /// The scene as TOML (camera, image size, transfer function).
    pub scene_toml: String,
    /// The whole volume's samples per axis, spacing, origin, field name.
    pub whole_dims: [u64; 3],
    /// See `whole_dims`.
    pub whole_spacing: [f64; 3],
    /// See `whole_dims`.
    pub whole_origin: [f64; 3],
    /// See `whole_dims`.
    pub field: String,
    /// The scalar range mapped to the transfer function's `[0, 1]`.
    pub range: [f64; 2],
    /// The whole volume's slice planes for this view (`None`: behind the
    /// eye); computed once at the coordinator.
    pub planes: Option<(f64, f64, u64)>,
    /// Slicer options.
    pub slice: WireSlice,
    /// The brick renderer.
    pub renderer: crate::node::grid::render::RendererKind,
    /// The layer codec (its depth is the layers' depth; travels as its
    /// name, and an unknown name fails decoding).
    pub codec: crate::compositor::codec::LayerCodecKind,
    /// The cost profile (charged as a model beside the measured times).
    pub profile: crate::node::CostProfile,
    /// This worker's bricks, in the order of the brick bytes.
    pub bricks: Vec<WireBrick>,
    /// SHA-256 of the brick bytes (the cache key).
    pub bricks_sha256: [u8; 32],
    /// Payload limit of frames.
    pub max_message_bytes: u64,
    /// Keep the bricks' textures for the next session with the same bricks
    /// (`--no-texture-cache` turns it off).
    pub texture_cache: bool,
    /// Phase 2 worker to worker: every rendering rank's address (rank `k`
    /// at `peers[k]`), the workers forming a mesh; empty: the layers go to
    /// the coordinator, the master (`--master`).
    pub peers: Vec<String>,
    /// The compositing strategy (with `peers`; travels as its name).
    pub compositor: crate::compositor::strategy::Compositing,
    /// Bricks in all, `d^3` (visibility ranks are below it).
    pub bricks_total: u32,
    /// Longest wait for a peer's message in phase 2, seconds.
    pub recv_timeout_s: f64,
    /// The frame's random id (see
    /// [`WorkerSetup::session_id`](super::session::WorkerSetup::session_id)).
    pub session_id: [u8; 16],
}

impl GridSetup {
    /// Checks what a worker cannot take on trust (brick boxes inside the
    /// whole, valid options; the codec and the strategy are known once
    /// decoded).
    pub fn validate(&self) -> Result<(), String> {
        if self.nodes == 0 || self.rank >= self.nodes {
            return Err(format!("rank {} of {} nodes", self.rank, self.nodes));
        }
        if !self.peers.is_empty() && self.peers.len() != self.nodes as usize {
            return Err(format!(
                "{} peer addresses for {} nodes",
                self.peers.len(),
                self.nodes
            ));
        }
        if !(self.recv_timeout_s.is_finite() && self.recv_timeout_s > 0.0) {
            return Err(format!("receive timeout {} s", self.recv_timeout_s));
        }
        if self.bricks.iter().any(|b| b.rank >= self.bricks_total) {
            return Err(format!(
                "a visibility rank at or above the brick count {}",
                self.bricks_total
            ));
        }
        self.slice.options()?;
        if !(self.range[0].is_finite()
            && self.range[1].is_finite()
            && self.range[1] > self.range[0])
        {
            return Err(format!("scalar range {:?}", self.range));
        }
        for b in &self.bricks {
            for a in 0..3 {
                if b.dims[a] < 2 || b.lo[a].saturating_add(b.dims[a]) > self.whole_dims[a] {
                    return Err(format!(
                        "brick {} ({:?} + {:?}) is not inside the volume {:?}",
                        b.id, b.lo, b.dims, self.whole_dims
                    ));
                }
            }
        }
        Ok(())
    }

    /// The planes.
    pub fn planes(&self) -> Option<Planes> {
        self.planes
            .map(|(z_start, delta, n)| Planes { z_start, delta, n })
    }
}

/// The wire tuple of `p`.
pub fn wire_planes(p: Option<Planes>) -> Option<(f64, f64, u64)> {
    p.map(|p| (p.z_start, p.delta, p.n))
}

/// Appends one volume's bytes.
fn put_volume(out: &mut Vec<u8>, v: &Volume) {
    for d in v.dims {
        out.extend_from_slice(&d.to_le_bytes());
    }
    for x in v.spacing.iter().chain(&v.origin) {
        out.extend_from_slice(&x.to_le_bytes());
    }
    match &v.voxels {
        Voxels::U8(s) => {
            out.push(0);
            out.extend_from_slice(s);
        }
        Voxels::U16(s) => {
            out.push(1);
            s.iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
        Voxels::I16(s) => {
            out.push(2);
            s.iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
        Voxels::F32(s) => {
            out.push(3);
            s.iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
    }
}

/// The bytes of `vols` (see the module docs).
pub fn encode_bricks(vols: &[&Volume]) -> Vec<u8> {
    let total: u64 = vols.iter().map(|v| v.voxels.bytes() + 73).sum();
    let mut out = Vec::with_capacity(4 + total as usize);
    out.extend_from_slice(&(vols.len() as u32).to_le_bytes());
    for v in vols {
        put_volume(&mut out, v);
    }
    out
}

struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: u64) -> Result<&'a [u8], String> {
        let left = (self.b.len() - self.at) as u64;
        if n > left {
            return Err(format!(
                "brick bytes truncated at byte {}: need {n}, {left} left",
                self.at
            ));
        }
        let s = &self.b[self.at..self.at + n as usize];
        self.at += n as usize;
        Ok(s)
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or([0; 8]),
        ))
    }

    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
}

/// Decodes [`encode_bricks`] bytes; `field` names the scalar.
pub fn decode_bricks(bytes: &[u8], field: &str) -> Result<Vec<Volume>, String> {
    let mut c = Cursor { b: bytes, at: 0 };
    let n = u32::from_le_bytes(c.take(4)?.try_into().unwrap_or([0; 4])) as u64;
    if n > bytes.len() as u64 / 73 {
        return Err(format!("{n} bricks in {} bytes", bytes.len()));
    }
    let mut out = Vec::with_capacity(n as usize);
    for k in 0..n {
        let dims = [c.u64()?, c.u64()?, c.u64()?];
        let spacing = [c.f64()?, c.f64()?, c.f64()?];
        let origin = [c.f64()?, c.f64()?, c.f64()?];
        let tag = c.take(1)?[0];
        let count = dims
            .iter()
            .try_fold(1u64, |a, &d| a.checked_mul(d))
            .ok_or_else(|| format!("brick {k}: {dims:?} samples overflow"))?;
        let width: u64 = match tag {
            0 => 1,
            1 | 2 => 2,
            3 => 4,
            t => return Err(format!("brick {k}: sample type tag {t}")),
        };
        let raw = c.take(
            count
                .checked_mul(width)
                .ok_or_else(|| format!("brick {k}: {dims:?} samples overflow"))?,
        )?;
        let voxels = match tag {
            0 => Voxels::U8(raw.to_vec()),
            1 => Voxels::U16(
                raw.chunks_exact(2)
                    .map(|b| u16::from_le_bytes([b[0], b[1]]))
                    .collect(),
            ),
            2 => Voxels::I16(
                raw.chunks_exact(2)
                    .map(|b| i16::from_le_bytes([b[0], b[1]]))
                    .collect(),
            ),
            _ => Voxels::F32(
                raw.chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                    .collect(),
            ),
        };
        let v = Volume::new(
            Path::new("(brick from the coordinator)"),
            dims,
            spacing,
            origin,
            field,
            voxels,
        )
        .map_err(|e| format!("brick {k}: {e}"))?;
        out.push(v);
    }
    if c.at != bytes.len() {
        return Err(format!(
            "brick bytes: {} trailing bytes",
            bytes.len() - c.at
        ));
    }
    Ok(out)
}

/// The grid messages inside [`Session::Grid`](super::session::Session::Grid).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum GridMsg {
    /// The worker's frame.
    Setup(Box<GridSetup>),
    /// What the worker rendered.
    Result(Box<GridResult>),
    /// Phase 2 worker to worker: the rank's log, after its last send.
    Done(Box<RankLog>),
}

/// A worker's frame result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GridResult {
    /// Its numbers (`host_s` is its measured render time).
    pub stats: GridNodeStats,
    /// Its layers cropped to the screen, empty ones dropped, as one
    /// [`encode`](crate::compositor::layer::exec::encode) message under the setup's codec (empty when
    /// the workers composite among themselves).
    pub layers: Vec<u8>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vol(dims: [u64; 3], f: impl Fn(u64) -> Voxels) -> Volume {
        Volume::new(
            Path::new("t"),
            dims,
            [1.0, 0.5, 2.0],
            [-1.0, 3.0, 0.25],
            "v",
            f(dims.iter().product()),
        )
        .unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]
        #[test]
        fn bricks_round_trip_and_bad_bytes_are_errors(
            d in prop::array::uniform3(2u64..5),
            tag in 0u8..4,
            cut in any::<prop::sample::Index>(),
            at in any::<prop::sample::Index>(),
            v in any::<u8>(),
        ) {
            let mk = |n: u64| match tag {
                0 => Voxels::U8((0..n).map(|i| i as u8).collect()),
                1 => Voxels::U16((0..n).map(|i| (i * 977) as u16).collect()),
                2 => Voxels::I16((0..n).map(|i| (i as i16).wrapping_mul(-331)).collect()),
                _ => Voxels::F32((0..n).map(|i| i as f32 * 0.37 - 2.0).collect()),
            };
            let a = vol(d, mk);
            let b = vol([d[2], d[0], d[1]], mk);
            let bytes = encode_bricks(&[&a, &b]);
            let back = decode_bricks(&bytes, "v").unwrap();
            prop_assert_eq!(back.len(), 2);
            for (x, y) in back.iter().zip([&a, &b]) {
                prop_assert_eq!(x.dims, y.dims);
                prop_assert_eq!(x.spacing, y.spacing);
                prop_assert_eq!(x.origin, y.origin);
                prop_assert_eq!(&x.voxels, &y.voxels);
            }
            prop_assert!(decode_bricks(&bytes[..cut.index(bytes.len())], "v").is_err());
            let mut m = bytes.clone();
            let i = at.index(m.len());
            m[i] = v;
            let _ = decode_bricks(&m, "v"); // never panics
            let mut long = bytes;
            long.push(0);
            prop_assert!(decode_bricks(&long, "v").is_err());
        }
    }

    #[test]
    fn slice_options_round_trip() {
        for o in [
            Slice3dOptions::default(),
            Slice3dOptions {
                classify: Classify::Preint,
                order: Order::BackToFront,
                ert: 1.0,
                slices: SliceCount::Spacing(0.25),
                empty_skip: false,
                brick: None,
            },
            Slice3dOptions {
                slices: SliceCount::Count(77),
                ..Default::default()
            },
        ] {
            assert_eq!(WireSlice::from(&o).options().unwrap(), o);
        }
        let mut w = WireSlice::from(&Slice3dOptions::default());
        w.order = 9;
        assert!(w.options().unwrap_err().contains("order"));
    }
}
