//! Fitting unit costs (pure functions; the timing loop is `pvrsim calibrate`).
//!
//! ## This machine: [`fit_profile`]
//!
//! Timed samples of three kinds, each fitted separately by non-negative
//! least squares ([`super::lsq::nnls`]) on the counters that kind of work
//! moves, weighted by `1 / t²` (relative errors: small and large samples
//! count alike):
//!
//! - receive (`add_work`): `vertices_projected`, `cells_received`;
//! - step: `cells_tested`, `cells_projected`, `pixels_tested`,
//!   `segments_generated`, `segments_merged`;
//! - update: `lists_walked`, `list_entries_walked`, `table_entries_updated`,
//!   `table_pixels_read`.
//!
//! Sharing and work packing are measured directly (time per entry, per
//! cell), and so is the exact integrator's price per piece of a segment
//! that crosses transfer-function control points (`segment_pieces`): the
//! step samples are fitted on what is left after that term.
//!
//! ## The paper's Pentium 4: [`fit_table1`]
//!
//! The paper gives four sequential times (Table 1). With our operation
//! counts for the same four runs, the compute time under a base profile
//! splits into a per-cell part `c_i` (receive, test, set-up) and a per-pixel
//! part `p_i` (pixel tests, segments, merges, ERT updates). The Pentium 4
//! profile is the base with the per-cell costs scaled by `k_c` and the rest
//! by `k_p`: `T_i = k_c c_i + k_p p_i`. Two unknowns: they are solved
//! exactly from the two runs **without** ERT (view A at 300 x 100 has about
//! one pixel per cell, view B at 300 x 300 about ten, so the system is well
//! conditioned), and the two runs **with** ERT are predictions — a check of
//! how well our ERT and our data match the paper's. A least-squares fit to
//! all four (relative errors) is reported too.

use serde::Serialize;

use super::cost::{breakdown, CostProfile};
use super::lsq::{nnls, Fit};
use super::ops::OpCounts;

/// Which operation a timed sample measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SampleKind {
    /// `add_work`.
    Receive,
    /// `step`.
    Step,
    /// `update_table`.
    Update,
}

/// One timed call.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sample {
    /// What was timed.
    pub kind: SampleKind,
    /// Its operation counts.
    pub ops: OpCounts,
    /// Seconds it took.
    pub secs: f64,
}

/// Quality of one of the fits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitQuality {
    /// Which kind.
    pub kind: SampleKind,
    /// Samples used.
    pub samples: usize,
    /// Weighted R² (relative errors).
    pub r2_weighted: f64,
    /// Unweighted R² of the same coefficients.
    pub r2: f64,
    /// Root mean square of the relative residuals `(t - model) / t`.
    pub rel_rms: f64,
    /// Sum of measured seconds and of modelled seconds.
    pub total_measured_s: f64,
    /// Modelled total.
    pub total_model_s: f64,
}

fn columns(kind: SampleKind, o: &OpCounts) -> Vec<f64> {
    let v: Vec<u64> = match kind {
        SampleKind::Receive => vec![o.vertices_projected, o.cells_received],
        SampleKind::Step => vec![
            o.cells_tested,
            o.cells_projected,
            o.pixels_tested,
            o.segments_generated,
            o.segments_merged,
        ],
        SampleKind::Update => vec![
            o.lists_walked,
            o.list_entries_walked,
            o.table_entries_updated,
            o.table_pixels_read,
        ],
    };
    v.into_iter().map(|x| x as f64).collect()
}

fn quality(kind: SampleKind, s: &[&Sample], f: &Fit) -> FitQuality {
    let y: Vec<f64> = s.iter().map(|x| x.secs).collect();
    let mean = y.iter().sum::<f64>() / y.len().max(1) as f64;
    let ss_tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let ss_res: f64 = f.residuals.iter().map(|r| r * r).sum();
    let rel: f64 = f
        .residuals
        .iter()
        .zip(&y)
        .map(|(r, v)| (r / v.max(1e-9)).powi(2))
        .sum::<f64>()
        / y.len().max(1) as f64;
    let total: f64 = y.iter().sum();
    FitQuality {
        kind,
        samples: s.len(),
        r2_weighted: f.r2,
        r2: if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            1.0
        },
        rel_rms: rel.sqrt(),
        total_measured_s: total,
        total_model_s: total - f.residuals.iter().sum::<f64>(),
    }
}

/// Costs measured directly rather than fitted.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Measured {
    /// Per shared-table entry merged.
    pub per_shared_entry: f64,
    /// Per cell packed or unpacked.
    pub per_work_cell: f64,
    /// Per piece of a crossing segment (subtracted from step samples).
    pub per_segment_piece: f64,
}

/// Fits the step, update and receive costs to `samples` (see the module
/// docs); the costs in `m` are given (measured directly).
pub fn fit_profile(samples: &[Sample], m: Measured) -> (CostProfile, Vec<FitQuality>) {
    let mut p = CostProfile {
        per_shared_entry: m.per_shared_entry,
        per_work_cell: m.per_work_cell,
        per_segment_piece: m.per_segment_piece,
        ..Default::default()
    };
    let mut q = Vec::new();
    for kind in [SampleKind::Receive, SampleKind::Step, SampleKind::Update] {
        let s: Vec<&Sample> = samples
            .iter()
            .filter(|x| x.kind == kind && x.secs > 0.0)
            .collect();
        if s.is_empty() {
            continue;
        }
        let x: Vec<Vec<f64>> = s.iter().map(|x| columns(kind, &x.ops)).collect();
        let y: Vec<f64> = s.iter().map(|x| x.secs).collect();
        let w: Vec<f64> = y.iter().map(|v| 1.0 / v.max(1e-7).powi(2)).collect();
        // The known term off (it stays in the quality figures below).
        let known = |x: &Sample| match kind {
            SampleKind::Step => x.ops.segment_pieces as f64 * m.per_segment_piece,
            _ => 0.0,
        };
        let y_rest: Vec<f64> = s.iter().zip(&y).map(|(x, v)| v - known(x)).collect();
        let f = nnls(&x, &y_rest, &w);
        let c = &f.coef;
        match kind {
            SampleKind::Receive => {
                p.per_vertex_project = c[0];
                p.per_cell_receive = c[1];
            }
            SampleKind::Step => {
                p.per_cell_test = c[0];
                p.per_cell_setup = c[1];
                p.per_pixel_test = c[2];
                p.per_segment = c[3];
                p.per_merge = c[4];
            }
            SampleKind::Update => {
                p.per_list_walked = c[0];
                p.per_list_entry_walked = c[1];
                p.per_table_entry = c[2];
                p.per_table_pixel = c[3];
            }
        }
        q.push(quality(kind, &s, &f));
    }
    (p, q)
}

/// One row of the paper's Table 1 and our counts for it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table1Row {
    /// Label, e.g. "A 300x100 no ERT".
    pub label: String,
    /// The paper's seconds.
    pub paper_s: f64,
    /// Our operation counts for the same run.
    pub ops: OpCounts,
    /// Whether this row is used to fit (`true`) or predicted.
    pub fitted: bool,
}

/// The result of [`fit_table1`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table1Fit {
    /// Per-cell scale.
    pub k_cell: f64,
    /// Per-pixel scale.
    pub k_pixel: f64,
    /// Per row: the paper's seconds, the model's, and whether fitted.
    pub rows: Vec<(String, f64, f64, bool)>,
    /// The same with the least-squares scales over all four rows.
    pub all_rows_k: (f64, f64),
    /// Model seconds per row with those.
    pub all_rows_model_s: Vec<f64>,
}

/// `(per-cell part, per-pixel part)` of the compute time of `ops` under `p`.
pub fn cell_pixel_parts(ops: &OpCounts, p: &CostProfile) -> (f64, f64) {
    let cell = p.scaled_split(1.0, 0.0);
    let pix = p.scaled_split(0.0, 1.0);
    let t = |q: &CostProfile| {
        let b = breakdown(ops, q);
        b.receive + b.ert_test + b.scan + b.ert_update + b.share + b.work
    };
    (t(&cell), t(&pix))
}

/// Fits `k_cell`, `k_pixel` exactly to the rows marked `fitted` (two of
/// them), predicts the others, and also fits all rows by relative least
/// squares. `None` if the two fitted rows do not determine the scales.
pub fn fit_table1(base: &CostProfile, rows: &[Table1Row]) -> Option<Table1Fit> {
    let parts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| cell_pixel_parts(&r.ops, base))
        .collect();
    let fitted: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].fitted).collect();
    let [a, b] = fitted[..] else { return None };
    let (c1, p1, t1) = (parts[a].0, parts[a].1, rows[a].paper_s);
    let (c2, p2, t2) = (parts[b].0, parts[b].1, rows[b].paper_s);
    let det = c1 * p2 - c2 * p1;
    if det.abs() < 1e-12 * (c1 * p2).abs().max(1e-300) {
        return None;
    }
    let k_cell = (t1 * p2 - t2 * p1) / det;
    let k_pixel = (c1 * t2 - c2 * t1) / det;
    let model =
        |kc: f64, kp: f64| -> Vec<f64> { parts.iter().map(|(c, p)| kc * c + kp * p).collect() };
    let m = model(k_cell, k_pixel);
    let x: Vec<Vec<f64>> = parts.iter().map(|&(c, p)| vec![c, p]).collect();
    let y: Vec<f64> = rows.iter().map(|r| r.paper_s).collect();
    let w: Vec<f64> = y.iter().map(|v| 1.0 / (v * v)).collect();
    let all = nnls(&x, &y, &w);
    Some(Table1Fit {
        k_cell,
        k_pixel,
        rows: rows
            .iter()
            .zip(&m)
            .map(|(r, &t)| (r.label.clone(), r.paper_s, t, r.fitted))
            .collect(),
        all_rows_k: (all.coef[0], all.coef[1]),
        all_rows_model_s: model(all.coef[0], all.coef[1]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table1_fit_is_exact_on_fitted_rows() {
        let base = CostProfile {
            per_cell_setup: 1e-6,
            per_pixel_test: 1e-8,
            ..Default::default()
        };
        let row = |cells: u64, px: u64, t: f64, fitted: bool| Table1Row {
            label: String::new(),
            paper_s: t,
            ops: OpCounts {
                cells_projected: cells,
                pixels_tested: px,
                ..Default::default()
            },
            fitted,
        };
        let rows = [
            row(1000, 1000, 10.0, true),
            row(1000, 20000, 30.0, true),
            row(500, 5000, 0.0, false),
        ];
        let f = fit_table1(&base, &rows).unwrap();
        assert!((f.rows[0].2 - 10.0).abs() < 1e-9 && (f.rows[1].2 - 30.0).abs() < 1e-9);
        // 1000 kc 1e-6 + 1000 kp 1e-8 = 10; 1000 kc 1e-6 + 20000 kp 1e-8 = 30.
        let kp = 20.0 / (19000.0 * 1e-8);
        assert!((f.k_pixel - kp).abs() / kp < 1e-9);
    }

    #[test]
    fn profile_fit_recovers_synthetic_costs() {
        let truth = CostProfile {
            per_cell_test: 2e-8,
            per_cell_setup: 3e-7,
            per_pixel_test: 1e-8,
            per_segment: 4e-8,
            per_merge: 1e-8,
            per_segment_piece: 5e-8,
            ..Default::default()
        };
        let samples: Vec<Sample> = (1..40u64)
            .map(|i| {
                let ops = OpCounts {
                    cells_tested: 1000 + i * 7,
                    cells_projected: 900 + (i * 37) % 100,
                    pixels_tested: 5000 * (i % 5 + 1),
                    segments_generated: 3000 * (i % 3 + 1) + i,
                    segments_merged: 100 * (i % 7),
                    segment_pieces: 200 * (i % 4),
                    ..Default::default()
                };
                Sample {
                    kind: SampleKind::Step,
                    secs: super::super::compute_time(&ops, &truth),
                    ops,
                }
            })
            .collect();
        // The piece cost given (measured directly): the rest is recovered
        // and the whole explained.
        let m = Measured {
            per_segment_piece: 5e-8,
            ..Default::default()
        };
        let (p, q) = fit_profile(&samples, m);
        assert!((p.per_cell_setup - 3e-7).abs() < 1e-12);
        assert!((p.per_segment - 4e-8).abs() < 1e-13);
        assert_eq!(p.per_segment_piece, 5e-8);
        assert!(q[0].r2 > 0.999999);
        assert!((q[0].total_model_s - q[0].total_measured_s).abs() < 1e-12);
    }
}
