//! The 2D warp of the intermediate image to the final image (the "warp"
//! half of shear-warp): each final pixel maps through the affine
//! [`Factor`] warp to a point of the intermediate image, resampled
//! bilinearly (intermediate pixel `(u, v)` holds the ray through `(u, v)`
//! exactly, zero outside), then composited over the background as the
//! other renderers do: `C + (1 - A) bg`, alpha `A`.

use rayon::prelude::*;

use super::factor::Factor;
use crate::image::Image;

/// Warps `inter` (`size` = width, height; premultiplied RGBA) into `image`
/// over background `bg`; returns the final pixels that met the
/// intermediate image.
pub fn warp(f: &Factor, inter: &[[f32; 4]], image: &mut Image, bg: [f32; 3]) -> u64 {
    let [wi, hi] = f.size;
    let w = image.width as usize;
    let at = |u: isize, v: isize| -> [f32; 4] {
        if u < 0 || v < 0 || u as usize >= wi || v as usize >= hi {
            [0.0; 4]
        } else {
            inter[v as usize * wi + u as usize]
        }
    };
    image
        .pixels
        .par_chunks_mut(w)
        .enumerate()
        .map(|(y, row)| {
            let mut covered = 0;
            for (x, px) in row.iter_mut().enumerate() {
                let p = f.warp_origin + f.warp_matrix * glam::DVec2::new(x as f64, y as f64);
                let (u0, v0) = (p.x.floor(), p.y.floor());
                let (fu, fv) = ((p.x - u0) as f32, (p.y - v0) as f32);
                let (u0, v0) = (u0 as isize, v0 as isize);
                let c = if u0 < -1 || v0 < -1 || u0 >= wi as isize || v0 >= hi as isize {
                    [0.0; 4]
                } else {
                    covered += 1;
                    let (a, b) = (at(u0, v0), at(u0 + 1, v0));
                    let (c, d) = (at(u0, v0 + 1), at(u0 + 1, v0 + 1));
                    std::array::from_fn(|i| {
                        let top = (b[i] - a[i]) * fu + a[i];
                        let bot = (d[i] - c[i]) * fu + c[i];
                        (bot - top) * fv + top
                    })
                };
                let t = 1.0 - c[3];
                *px = [c[0] + t * bg[0], c[1] + t * bg[1], c[2] + t * bg[2], c[3]];
            }
            covered
        })
        .sum()
}
