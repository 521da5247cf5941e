//! The 2D warp of the intermediate image to the final image (the "warp"
//! half of shear-warp): each final pixel maps through the affine
//! [`Factor`] warp to a point of the intermediate image, resampled
//! bilinearly (intermediate pixel `(u, v)` holds the ray through `(u, v)`
//! exactly, zero outside), then composited over the background as the
//! other renderers do: `C + (1 - A) bg`, alpha `A`.

use glam::Vec4;
use rayon::prelude::*;

use super::factor::Factor;

/// Edge of the square tiles of final pixels warped together.
const TILE: usize = 8;
use crate::image::Image;

/// Warps `inter` (`size` = width, height; premultiplied RGBA) into `image`
/// over background `bg`; returns the final pixels that met the
/// intermediate image.
pub fn warp(f: &Factor, inter: &[[f32; 4]], image: &mut Image, bg: [f32; 3]) -> u64 {
    let [wi, hi] = f.size;
    let w = image.width as usize;
    let px_at = |u: isize, v: isize| -> Vec4 {
        if u < 0 || v < 0 || u as usize >= wi || v as usize >= hi {
            Vec4::ZERO
        } else {
            Vec4::from_array(inter[v as usize * wi + u as usize])
        }
    };
    let bg = Vec4::new(bg[0], bg[1], bg[2], 0.0);
    let m = f.warp_matrix;
    // Bands of TILE rows walked in TILE-square tiles: a tile's four
    // neighbours lie close together in the intermediate image (a final row
    // crosses it at an angle; whole rows would miss the cache).
    image
        .pixels
        .par_chunks_mut(w * TILE)
        .enumerate()
        .map(|(band, rows)| {
            let mut covered = 0;
            let nrows = rows.len() / w;
            for x0 in (0..w).step_by(TILE) {
                for dy in 0..nrows {
                    let y = band * TILE + dy;
                    let p0 = f.warp_origin + m.y_axis * y as f64;
                    for x in x0..(x0 + TILE).min(w) {
                        let px = &mut rows[dy * w + x];
                        let p = p0 + m.x_axis * x as f64;
                        // floor without a libm call: truncation of a value made
                        // positive (below -2 the pixel is outside, where a wrong
                        // fraction does not matter).
                        let (su, sv) = (p.x + 2.0, p.y + 2.0);
                        let (u0, v0) = (su as isize - 2, sv as isize - 2);
                        let fu = (su - (u0 + 2) as f64) as f32;
                        let fv = (sv - (v0 + 2) as f64) as f32;
                        let c = if u0 >= 0
                            && v0 >= 0
                            && (u0 as usize) + 1 < wi
                            && (v0 as usize) + 1 < hi
                        {
                            // Inside: the four neighbours without bounds tests.
                            covered += 1;
                            let k = v0 as usize * wi + u0 as usize;
                            let q = &inter[k..k + wi + 2];
                            let (a, b) = (Vec4::from_array(q[0]), Vec4::from_array(q[1]));
                            let (c, d) = (Vec4::from_array(q[wi]), Vec4::from_array(q[wi + 1]));
                            let top = (b - a) * fu + a;
                            let bot = (d - c) * fu + c;
                            (bot - top) * fv + top
                        } else if u0 < -1 || v0 < -1 || u0 >= wi as isize || v0 >= hi as isize {
                            Vec4::ZERO
                        } else {
                            covered += 1;
                            let (a, b) = (px_at(u0, v0), px_at(u0 + 1, v0));
                            let (c, d) = (px_at(u0, v0 + 1), px_at(u0 + 1, v0 + 1));
                            let top = (b - a) * fu + a;
                            let bot = (d - c) * fu + c;
                            (bot - top) * fv + top
                        };
                        let out = c + bg * (1.0 - c.w);
                        *px = [out.x, out.y, out.z, c.w];
                    }
                }
            }
            covered
        })
        .sum()
}
