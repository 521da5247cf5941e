//! Rectangles of the screen: areas, containment, and the two ways strategies
//! cut the screen (halves for binary swap, row strips for direct send).

use crate::base::Rect;

/// Pixels in `r`.
#[inline]
pub fn area(r: &Rect) -> usize {
    r.width() as usize * r.height() as usize
}

/// Whether `inner` lies inside `outer` (an empty `inner` lies anywhere inside).
pub fn contains(outer: &Rect, inner: &Rect) -> bool {
    area(inner) == 0
        || (outer.x0 <= inner.x0
            && inner.x1 <= outer.x1
            && outer.y0 <= inner.y0
            && inner.y1 <= outer.y1)
}

/// Whether `a` and `b` share a pixel.
pub fn overlaps(a: &Rect, b: &Rect) -> bool {
    a.x0.max(b.x0) < a.x1.min(b.x1) && a.y0.max(b.y0) < a.y1.min(b.y1)
}

/// Whether `r` is well formed (`x0 <= x1`, `y0 <= y1`).
pub fn is_valid(r: &Rect) -> bool {
    r.x0 <= r.x1 && r.y0 <= r.y1
}

/// The whole `width x height` screen.
pub fn screen(width: u32, height: u32) -> Rect {
    Rect {
        x0: 0,
        y0: 0,
        x1: width,
        y1: height,
    }
}

/// Cuts `r` across its longer side into two halves of equal pixel count
/// (the first gets the smaller half when the side is odd). Binary swap's cut.
pub fn halves(r: &Rect) -> (Rect, Rect) {
    if r.width() >= r.height() {
        let xm = r.x0 + r.width() / 2;
        (Rect { x1: xm, ..*r }, Rect { x0: xm, ..*r })
    } else {
        let ym = r.y0 + r.height() / 2;
        (Rect { y1: ym, ..*r }, Rect { y0: ym, ..*r })
    }
}

/// Cuts `r` across its longer side into `k` pieces of about equal pixel
/// count, in order (left to right or top to bottom); piece `j` spans
/// `[j L / k, (j + 1) L / k)` of the side's length `L`, so pieces are empty
/// when `k > L`. Radix-k's cut (binary swap's `halves` is `k = 2` up to
/// which half gets the odd row).
pub fn pieces(r: &Rect, k: usize) -> Vec<Rect> {
    let k = k.max(1);
    let along_x = r.width() >= r.height();
    let len = if along_x { r.width() } else { r.height() } as usize;
    (0..k)
        .map(|j| {
            let a = (j * len / k) as u32;
            let b = ((j + 1) * len / k) as u32;
            if along_x {
                Rect {
                    x0: r.x0 + a,
                    x1: r.x0 + b,
                    ..*r
                }
            } else {
                Rect {
                    y0: r.y0 + a,
                    y1: r.y0 + b,
                    ..*r
                }
            }
        })
        .collect()
}

/// Cuts `r` into `n` full-width row strips, top to bottom, of about equal
/// weight: equal pixel count without `row_weight`, else about equal sum of
/// `row_weight` (one entry per row of `r`, non-negative). Strips may be
/// empty when `n` exceeds the rows.
pub fn strips(r: &Rect, n: usize, row_weight: Option<&[f64]>) -> Vec<Rect> {
    let h = r.height() as usize;
    let mut cuts = vec![0usize; n + 1];
    match row_weight {
        Some(w) if w.len() == h && w.iter().sum::<f64>() > 0.0 => {
            let total: f64 = w.iter().sum();
            let mut acc = 0.0;
            let mut row = 0;
            for (k, cut) in cuts.iter_mut().enumerate().skip(1) {
                let target = total * k as f64 / n as f64;
                while row < h && acc + 0.5 * w[row] < target {
                    acc += w[row];
                    row += 1;
                }
                *cut = if k == n { h } else { row };
            }
        }
        _ => {
            for (k, cut) in cuts.iter_mut().enumerate() {
                *cut = k * h / n.max(1);
            }
        }
    }
    cuts.windows(2)
        .map(|c| Rect {
            x0: r.x0,
            x1: r.x1,
            y0: r.y0 + c[0] as u32,
            y1: r.y0 + c[1] as u32,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_and_strips_cover_exactly() {
        let r = Rect {
            x0: 3,
            y0: 5,
            x1: 104,
            y1: 40,
        };
        let (a, b) = halves(&r);
        assert_eq!(area(&a) + area(&b), area(&r));
        assert!(!overlaps(&a, &b) && contains(&r, &a) && contains(&r, &b));
        for n in [1, 2, 3, 7, 35, 50] {
            let s = strips(&r, n, None);
            assert_eq!(s.len(), n);
            assert_eq!(s.iter().map(area).sum::<usize>(), area(&r));
        }
        let w: Vec<f64> = (0..35).map(|y| if y < 5 { 10.0 } else { 1.0 }).collect();
        for k in [1, 2, 3, 8, 101, 200] {
            let p = pieces(&r, k);
            assert_eq!(p.len(), k);
            assert_eq!(p.iter().map(area).sum::<usize>(), area(&r));
            for (i, a) in p.iter().enumerate() {
                assert!(contains(&r, a));
                assert!(p[i + 1..].iter().all(|b| !overlaps(a, b)));
            }
        }
        let s = strips(&r, 4, Some(&w));
        assert_eq!(s.iter().map(area).sum::<usize>(), area(&r));
        assert!(s[0].height() < s[3].height(), "{s:?}");
    }
}
