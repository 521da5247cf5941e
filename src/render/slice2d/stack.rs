//! The 2D textures of `slice2d`: the volume's sample planes perpendicular
//! to the slicing axis, each with the mip levels the frame needs (2 x 2 box
//! averaging) and 8 x 8-texel min–max tiles for empty-space skipping.
//!
//! Level `L` of a slice of `nu x nv` texels has `ceil(n / 2)` texels per
//! axis of level `L - 1`, texel `(i, j)` the mean of texels `(2i, 2j)`,
//! `(2i+1, 2j)`, `(2i, 2j+1)`, `(2i+1, 2j+1)` (an odd edge repeats its last
//! texel). Its centre lies at level-0 coordinate `2^L (i + 1/2) - 1/2`, so a
//! level-0 coordinate `u` reads level `L` at `(u + 1/2) / 2^L - 1/2`.

use crate::data::Volume;

/// Texels per tile edge of the min–max tiles.
pub const TILE: usize = 8;

/// One level of one slice: `nu x nv` texels of `C` channels (1: the scalar,
/// post-classification; 4: `(c o, o)`, pre-classification), u fastest.
#[derive(Debug, Clone)]
pub struct Level<const C: usize> {
    /// Texels along u and v.
    pub n: [usize; 2],
    /// Texels.
    pub texels: Vec<[f32; C]>,
    /// Tiles along u and v.
    pub nt: [usize; 2],
    /// `[min, max]` of the channel that decides transparency (the scalar,
    /// or the opacity) per tile, over texels `[T t, T t + T]`.
    pub tiles: Vec<[f32; 2]>,
}

impl<const C: usize> Level<C> {
    /// A level from its texels; builds the tiles over channel `C - 1`.
    pub fn new(n: [usize; 2], texels: Vec<[f32; C]>) -> Level<C> {
        let nt = [
            (n[0].max(2) - 1).div_ceil(TILE),
            (n[1].max(2) - 1).div_ceil(TILE),
        ];
        let mut tiles = vec![[f32::INFINITY, f32::NEG_INFINITY]; nt[0] * nt[1]];
        for (tv, trow) in tiles.chunks_mut(nt[0]).enumerate() {
            for (tu, t) in trow.iter_mut().enumerate() {
                for v in tv * TILE..=((tv + 1) * TILE).min(n[1] - 1) {
                    for u in tu * TILE..=((tu + 1) * TILE).min(n[0] - 1) {
                        let x = texels[v * n[0] + u][C - 1];
                        t[0] = t[0].min(x);
                        t[1] = t[1].max(x);
                    }
                }
            }
        }
        Level {
            n,
            texels,
            nt,
            tiles,
        }
    }

    /// The next coarser level (2 x 2 box average).
    pub fn halve(&self) -> Level<C> {
        let n = [self.n[0].div_ceil(2), self.n[1].div_ceil(2)];
        let mut t = Vec::with_capacity(n[0] * n[1]);
        for j in 0..n[1] {
            let (j0, j1) = (2 * j, (2 * j + 1).min(self.n[1] - 1));
            for i in 0..n[0] {
                let (i0, i1) = (2 * i, (2 * i + 1).min(self.n[0] - 1));
                let g = |u: usize, v: usize| self.texels[v * self.n[0] + u];
                let (a, b, c, d) = (g(i0, j0), g(i1, j0), g(i0, j1), g(i1, j1));
                t.push(std::array::from_fn(|ch| {
                    0.25 * (a[ch] + b[ch] + c[ch] + d[ch])
                }));
            }
        }
        Level::new(n, t)
    }

    /// Bytes in a texture format of `bytes_per_texel`.
    pub fn bytes(&self, bytes_per_texel: u64) -> u64 {
        (self.n[0] * self.n[1]) as u64 * bytes_per_texel
    }
}

/// The in-plane axes `(u, v)` of slicing axis `a` (right-handed order kept).
pub fn plane_axes(a: usize) -> (usize, usize) {
    match a {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Level 0 of slice `m` along axis `a`, channel values from `f(voxel value)`.
pub fn slice<const C: usize>(
    vol: &Volume,
    a: usize,
    m: u64,
    f: impl Fn(f32) -> [f32; C],
) -> Level<C> {
    let (ua, va) = plane_axes(a);
    let n = [vol.dims[ua] as usize, vol.dims[va] as usize];
    let mut t = Vec::with_capacity(n[0] * n[1]);
    for v in 0..n[1] as u64 {
        for u in 0..n[0] as u64 {
            let mut ijk = [0u64; 3];
            ijk[a] = m;
            ijk[ua] = u;
            ijk[va] = v;
            t.push(f(vol.get(ijk[0], ijk[1], ijk[2])));
        }
    }
    Level::new(n, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halving_averages_and_keeps_odd_edges() {
        let l = Level::<1>::new([3, 2], vec![[0.0], [2.0], [4.0], [6.0], [8.0], [10.0]]);
        let h = l.halve();
        assert_eq!(h.n, [2, 1]);
        assert_eq!(h.texels, vec![[4.0], [7.0]]);
        assert_eq!(l.tiles, vec![[0.0, 10.0]]);
    }
}
