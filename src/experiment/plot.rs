//! PNG plots of a sweep's results (plotters, bitmap backend, DejaVu Sans
//! embedded through the `dejavu` crate, so no system fonts are needed).
//!
//! A line plot shows, per series and y column, the median over repetitions
//! at each x; a scatter plot shows every successful run as a dot. Series
//! are the combinations of the `series` parameters' values. A non-numeric x
//! (e.g. `integrator`) is drawn as categories in sweep order.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;

use super::config::{Plan, PlotKind, PlotSpec};
use super::results::{median, suggest, Results, Row, OK};

/// Plot size in pixels.
pub const SIZE: (u32, u32) = (900, 600);

pub(crate) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

pub use crate::text::register_fonts;

/// Whether a CSV value matches a `where` value: equal text, or equal numbers
/// (`1` matches `1.0`).
fn same_value(csv: &str, want: &str) -> bool {
    csv == want || matches!((csv.parse::<f64>(), want.parse::<f64>()), (Ok(a), Ok(b)) if a == b)
}

/// A legend value: a path is shown by its file stem (`aorta-view-b`).
fn short_value(v: &str) -> String {
    if v.contains('/') {
        Path::new(v)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| v.to_string())
    } else {
        v.to_string()
    }
}

/// One series of points.
#[derive(Debug, Clone)]
struct Series {
    label: String,
    points: Vec<(f64, f64)>,
}

/// The error for a plot whose `x` or `y` names a column that no run has
/// (and no parameter): the config is wrong, so `pvrsim sweep` fails.
pub fn unknown_column(plan: &Plan, spec: &PlotSpec, results: &Results) -> Option<String> {
    let file = plan.path.display();
    let known: Vec<String> = results.known_columns();
    let params = plan.param_names();
    for c in std::iter::once(&spec.x).chain(&spec.y) {
        if !known.contains(c) && !params.contains(c) {
            let key = if *c == spec.x { "x" } else { "y" };
            return Some(format!(
                "{file}: {}.{key}: no run has a column `{c}`{}",
                spec.key,
                suggest(c, &known)
            ));
        }
    }
    None
}

/// Draws one plot into `out_dir`; returns warnings (skipped points,
/// unknown columns). An error means the plot could not be drawn at all.
pub fn draw(
    plan: &Plan,
    spec: &PlotSpec,
    results: &Results,
    out_dir: &Path,
) -> Result<Vec<String>, String> {
    let mut warnings = Vec::new();
    let file = plan.path.display();
    if let Some(e) = unknown_column(plan, spec, results) {
        return Err(e);
    }
    // Successful rows of the plan's points, in sweep order.
    let points = plan.points();
    let rows: Vec<&Row> = points
        .iter()
        .flat_map(|p| results.rows_of(p))
        .filter(|r| r.get("status").map(String::as_str) == Some(OK))
        .filter(|r| {
            spec.filter
                .iter()
                .all(|(k, v)| r.get(k).is_some_and(|x| same_value(x, v)))
        })
        .collect();
    if rows.is_empty() {
        return Err(format!("{file}: {}: no successful run to plot", spec.key));
    }
    let get = |r: &Row, c: &str| r.get(c).cloned().unwrap_or_default();
    // Categorical x when any x value is not a number.
    let categorical = rows.iter().any(|r| get(r, &spec.x).parse::<f64>().is_err());
    let mut categories: Vec<String> = Vec::new();
    if categorical {
        for r in &rows {
            let v = get(r, &spec.x);
            if !categories.contains(&v) {
                categories.push(v);
            }
        }
    }
    let x_of = |r: &Row| -> Option<f64> {
        let v = get(r, &spec.x);
        if categorical {
            categories.iter().position(|c| *c == v).map(|i| i as f64)
        } else {
            v.parse().ok()
        }
    };
    // Per series label: (x, the y values at that x).
    type Raw = (String, Vec<(f64, Vec<f64>)>);
    let mut series: Vec<Raw> = Vec::new();
    let mut dropped = 0usize;
    for y in &spec.y {
        for r in &rows {
            let mut parts: Vec<String> = Vec::new();
            if spec.y.len() > 1 {
                parts.push(y.clone());
            }
            parts.extend(
                spec.series
                    .iter()
                    .map(|s| format!("{s}={}", short_value(&get(r, s)))),
            );
            let label = parts.join(", ");
            let (Some(x), Ok(yv)) = (x_of(r), get(r, y).parse::<f64>()) else {
                dropped += 1;
                continue;
            };
            if (spec.log_x && !categorical && x <= 0.0)
                || (spec.log_y && yv <= 0.0)
                || !x.is_finite()
                || !yv.is_finite()
            {
                dropped += 1;
                continue;
            }
            let i = match series.iter().position(|(l, _)| *l == label) {
                Some(i) => i,
                None => {
                    series.push((label, Vec::new()));
                    series.len() - 1
                }
            };
            let pts = &mut series[i].1;
            match (spec.kind, pts.iter_mut().find(|(px, _)| *px == x)) {
                (PlotKind::Line, Some((_, ys))) => ys.push(yv),
                _ => pts.push((x, vec![yv])),
            }
        }
    }
    if dropped > 0 {
        let why = if spec.log_x || spec.log_y {
            "missing, not numeric, or not > 0 on a log axis"
        } else {
            "missing or not numeric"
        };
        warnings.push(format!(
            "{file}: {}: {dropped} value(s) left out ({why})",
            spec.key
        ));
    }
    let series: Vec<Series> = series
        .into_iter()
        .map(|(label, pts)| {
            let mut points: Vec<(f64, f64)> = pts
                .into_iter()
                .flat_map(|(x, ys)| {
                    if spec.kind == PlotKind::Line {
                        vec![(x, median(&ys).unwrap_or(0.0))]
                    } else {
                        ys.into_iter().map(|y| (x, y)).collect()
                    }
                })
                .collect();
            if spec.kind == PlotKind::Line {
                points.sort_by(|a, b| a.0.total_cmp(&b.0));
            }
            Series { label, points }
        })
        .collect();
    if series.iter().all(|s| s.points.is_empty()) {
        return Err(format!("{file}: {}: nothing to plot", spec.key));
    }
    let path = out_dir.join(&spec.file);
    render(spec, &series, &categories, &path)
        .map_err(|e| format!("{file}: {}: cannot draw {}: {e}", spec.key, path.display()))?;
    Ok(warnings)
}

/// An axis label: the shortest text for a tick value (0.18, 2500, 1e-5).
fn tick(x: f64) -> String {
    let trim = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if x == 0.0 {
        "0".into()
    } else if x.abs() >= 1e6 || x.abs() < 1e-3 {
        let s = format!("{x:.3e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{e}", trim(m.to_string()))
    } else {
        trim(format!("{x:.6}"))
    }
}

fn bounds(v: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    if log {
        if lo == hi {
            return (lo / 2.0, hi * 2.0);
        }
        let f = (hi / lo).powf(0.05);
        return (lo / f, hi * f);
    }
    if lo == hi {
        let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        lo -= d;
        hi += d;
        return (lo, hi);
    }
    let pad = (hi - lo) * 0.05;
    (lo - pad, hi + pad)
}

fn render(
    spec: &PlotSpec,
    series: &[Series],
    categories: &[String],
    path: &Path,
) -> Result<(), Box<dyn std::error::Error>> {
    register_fonts();
    let all = || series.iter().flat_map(|s| s.points.iter());
    let (mut x0, mut x1) = bounds(all().map(|p| p.0), spec.log_x);
    if !categories.is_empty() {
        (x0, x1) = (-0.5, categories.len() as f64 - 0.5);
    }
    let (y0, y1) = bounds(all().map(|p| p.1), spec.log_y);
    let log_x = spec.log_x && categories.is_empty();
    match (log_x, spec.log_y) {
        (false, false) => chart(spec, series, categories, path, x0..x1, y0..y1),
        (true, false) => chart(spec, series, categories, path, (x0..x1).log_scale(), y0..y1),
        (false, true) => chart(spec, series, categories, path, x0..x1, (y0..y1).log_scale()),
        (true, true) => chart(
            spec,
            series,
            categories,
            path,
            (x0..x1).log_scale(),
            (y0..y1).log_scale(),
        ),
    }
}

fn chart<XR, YR>(
    spec: &PlotSpec,
    series: &[Series],
    categories: &[String],
    path: &Path,
    xr: XR,
    yr: YR,
) -> Result<(), Box<dyn std::error::Error>>
where
    XR: AsRangedCoord<Value = f64>,
    YR: AsRangedCoord<Value = f64>,
    XR::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YR::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(&spec.title, ("sans-serif", 24))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(84)
        .build_cartesian_2d(xr, yr)?;
    let x_fmt = |v: &f64| -> String {
        if categories.is_empty() {
            tick(*v)
        } else if (v - v.round()).abs() < 1e-6 && v.round() >= 0.0 {
            categories
                .get(v.round() as usize)
                .cloned()
                .unwrap_or_default()
        } else {
            String::new()
        }
    };
    let y_fmt = |v: &f64| tick(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(format!(
        "{}{}",
        spec.x,
        if spec.log_x && categories.is_empty() {
            " (log)"
        } else {
            ""
        }
    ))
    .y_desc(format!(
        "{}{}",
        spec.y.join(", "),
        if spec.log_y { " (log)" } else { "" }
    ))
    .label_style(("sans-serif", 15))
    .axis_desc_style(("sans-serif", 18))
    .x_label_formatter(&x_fmt)
    .y_label_formatter(&y_fmt);
    if !categories.is_empty() {
        mesh.x_labels(categories.len() * 2 + 1).disable_x_mesh();
    }
    mesh.draw()?;
    let labelled = series.iter().any(|s| !s.label.is_empty());
    for (i, s) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let style = ShapeStyle::from(&color).filled();
        let anno = match spec.kind {
            PlotKind::Line => {
                chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 4, style)))?;
                chart.draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    color.stroke_width(2),
                ))?
            }
            PlotKind::Scatter => {
                chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 5, style)))?
            }
        };
        if labelled {
            anno.label(s.label.clone()).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 14, y + 5)], color.filled())
            });
        }
    }
    if labelled {
        chart
            .configure_series_labels()
            .position(match spec.legend.as_str() {
                "upper-left" => SeriesLabelPosition::UpperLeft,
                "lower-left" => SeriesLabelPosition::LowerLeft,
                "lower-right" => SeriesLabelPosition::LowerRight,
                "upper-middle" => SeriesLabelPosition::UpperMiddle,
                "lower-middle" => SeriesLabelPosition::LowerMiddle,
                "middle-left" => SeriesLabelPosition::MiddleLeft,
                "middle-right" => SeriesLabelPosition::MiddleRight,
                _ => SeriesLabelPosition::UpperRight,
            })
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font(("sans-serif", 15))
            .draw()?;
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn where_values_match_as_text_or_number() {
        assert!(same_value("1", "1.0"));
        assert!(same_value("0.9", "0.9"));
        assert!(same_value("flat", "flat"));
        assert!(!same_value("0.9", "0.95"));
        assert!(!same_value("flat", "pyramid"));
    }

    #[test]
    fn legend_values_shorten_paths() {
        assert_eq!(
            short_value("../../shared/data/aorta-view-b.toml"),
            "aorta-view-b"
        );
        assert_eq!(short_value("0.9"), "0.9");
    }
}
