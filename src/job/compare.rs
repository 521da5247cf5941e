//! `render --compare`: the verdict (is the error within the bound that
//! applies?) and the labelled side-by-side strip.
//!
//! The bound on max-abs, in 1/255 units, is the sum of
//!
//! - the integrator's: `exact` is held to 2/255 (max-abs) and 0.5/255 (RMSE)
//!   against the reference (docs/accuracy.md, tests/accuracy.rs);
//!   `midpoint` has no bound (one lookup per segment; tens of 1/255 on the
//!   aorta scenes), so its verdict is "no bound applies";
//! - ERT's: `(1 - threshold) x max emitted radiance` (`ert_error_bound`),
//!   the light a terminated pixel may drop.

use std::path::Path;

use plotters::prelude::*;

use crate::image::{Image, ImageError};
use crate::render::cell::Integrator;

/// max-abs bound of the exact integrator against the reference (1/255).
pub const EXACT_MAX_ABS: f64 = 2.0;
/// RMSE bound of the exact integrator against the reference (1/255).
pub const EXACT_RMSE: f64 = 0.5;

/// The bound that applies and whether the error keeps it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Verdict {
    /// max-abs bound (1/255), `None` when no bound applies.
    pub max_abs_bound: Option<f64>,
    /// RMSE bound (1/255), `None` when no bound applies.
    pub rmse_bound: Option<f64>,
    /// Both errors within their bounds (`None`: no bound applies).
    pub within: Option<bool>,
    /// The sentence printed.
    pub text: String,
}

/// The verdict for `err` of a cell render with `integrator` and ERT error
/// bound `ert_bound` (0..1 units; 0 without ERT).
pub fn verdict(err: &ImageError, integrator: Integrator, ert_bound: f64) -> Verdict {
    let ert255 = 255.0 * ert_bound;
    if integrator != Integrator::Exact {
        return Verdict {
            max_abs_bound: None,
            rmse_bound: None,
            within: None,
            text: "verdict: no bound applies to the midpoint integrator (one lookup per segment; see docs/accuracy.md); use --integrator exact for a checked image".into(),
        };
    }
    let max_b = EXACT_MAX_ABS + ert255;
    let rmse_b = EXACT_RMSE + ert255;
    let ok = err.max_abs <= max_b && err.rmse <= rmse_b;
    let terms = if ert_bound > 0.0 {
        format!("exact integrator {EXACT_MAX_ABS}/255 + ERT {ert255:.2}/255")
    } else {
        format!("exact integrator {EXACT_MAX_ABS}/255, ERT off")
    };
    Verdict {
        max_abs_bound: Some(max_b),
        rmse_bound: Some(rmse_b),
        within: Some(ok),
        text: format!(
            "verdict: {} the bound: max-abs {:.3}/255 {} {:.2}/255 ({terms}), RMSE {:.3}/255 {} {:.2}/255",
            if ok { "WITHIN" } else { "OUTSIDE" },
            err.max_abs,
            if err.max_abs <= max_b { "<=" } else { ">" },
            max_b,
            err.rmse,
            if err.rmse <= rmse_b { "<=" } else { ">" },
            rmse_b
        ),
    }
}

/// Height of the label band above the images (pixels).
const BAND: u32 = 30;

/// Writes `this | reference | gain x |difference|` side by side with a label
/// above each image and the difference's scale, readable down to 100-pixel
/// images (13-pixel text; the strip is at least 3 x 120 pixels wide).
pub fn write_strip(
    this: &Image,
    reference: &Image,
    this_label: &str,
    gain: f32,
    path: &Path,
) -> anyhow::Result<()> {
    crate::text::register_fonts();
    let diff = Image::difference(this, reference, gain);
    let gap = 6u32;
    let cell_w = this.width.max(120);
    let w = 3 * cell_w + 2 * gap;
    let h = this.height + BAND;
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let full_white = format!("white = {:.1}/255", 255.0 / gain);
        let labels = [
            (this_label.to_string(), String::new()),
            ("reference (f64)".to_string(), String::new()),
            (format!("difference x {gain}"), full_white),
        ];
        for (k, (im, (l1, l2))) in [this, reference, &diff].iter().zip(labels).enumerate() {
            let x0 = k as u32 * (cell_w + gap);
            let style = ("sans-serif", 13).into_font().color(&BLACK);
            root.draw(&Text::new(l1, (x0 as i32 + 2, 1), style.clone()))?;
            if !l2.is_empty() {
                root.draw(&Text::new(l2, (x0 as i32 + 2, 15), style))?;
            }
            let rgb = im.to_rgb8();
            for j in 0..im.height {
                for i in 0..im.width {
                    let p = 3 * (j * im.width + i) as usize;
                    root.draw_pixel(
                        ((x0 + i) as i32, (BAND + j) as i32),
                        &RGBColor(rgb[p], rgb[p + 1], rgb[p + 2]),
                    )?;
                }
            }
        }
        root.present()?;
    }
    image::save_buffer(path, &buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(max_abs: f64, rmse: f64) -> ImageError {
        ImageError {
            max_abs,
            rmse,
            pixels_over_1: 0,
            worst_pixel: (0, 0),
        }
    }

    #[test]
    fn verdict_adds_the_ert_bound() {
        let v = verdict(&err(3.0, 0.1), Integrator::Exact, 0.0);
        assert_eq!(v.within, Some(false));
        assert!(v.text.starts_with("verdict: OUTSIDE"), "{}", v.text);
        // 0.01 x radiance 1 = 2.55/255: 3.0 < 4.55.
        let v = verdict(&err(3.0, 0.1), Integrator::Exact, 0.01);
        assert_eq!(v.within, Some(true));
        assert!(v.text.contains("ERT 2.55/255"), "{}", v.text);
        let v = verdict(&err(0.0, 0.0), Integrator::Midpoint, 0.0);
        assert_eq!(v.within, None);
    }
}
