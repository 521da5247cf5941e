//! `pvrsim fidelity` plots: per phase, modelled against measured seconds
//! on log-log axes with the diagonal (a perfect model) and the ±25 % lines;
//! one colour per workload, transport and link (the sweep plots' palette
//! and fonts, [`super::plot`]).

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::fidelity_rows::Row;
use super::plot::{register_fonts, PALETTE, SIZE};

/// Draws `fidelity-PHASE.png` into `out` for every phase with a point;
/// returns the files.
pub fn draw_all(rows: &[Row], out: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut phases: Vec<&str> = Vec::new();
    for r in rows {
        if !phases.contains(&r.phase.as_str()) {
            phases.push(&r.phase);
        }
    }
    let mut files = Vec::new();
    for p in phases {
        let pts: Vec<&Row> = rows
            .iter()
            .filter(|r| r.phase == p && r.measured_s > 0.0 && r.modelled_s > 0.0)
            .collect();
        if pts.is_empty() {
            continue;
        }
        let path = out.join(format!("fidelity-{p}.png"));
        draw(p, &pts, &path).map_err(|e| anyhow::anyhow!("plot {}: {e}", path.display()))?;
        files.push(path);
    }
    Ok(files)
}

fn draw(phase: &str, pts: &[&Row], path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    register_fonts();
    let lo = pts
        .iter()
        .flat_map(|r| [r.measured_s, r.modelled_s])
        .fold(f64::INFINITY, f64::min)
        / 1.5;
    let hi = pts
        .iter()
        .flat_map(|r| [r.measured_s, r.modelled_s])
        .fold(0.0f64, f64::max)
        * 1.5;
    let clock = &pts[0].clock;
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{phase}: modelled vs measured ({clock} clock measured)"),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((lo..hi).log_scale(), (lo..hi).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(format!("measured seconds ({clock})"))
        .y_desc("modelled seconds")
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()?;
    let diag = [(lo, lo), (hi, hi)];
    chart
        .draw_series(LineSeries::new(diag, BLACK.stroke_width(2)))?
        .label("modelled = measured")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK.stroke_width(2)));
    for (k, style) in [(1.25, "+25 %"), (0.75, "-25 %")] {
        let line = [(lo, lo * k), (hi, hi * k)];
        chart
            .draw_series(LineSeries::new(line, BLACK.mix(0.35)))?
            .label(style)
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK.mix(0.35)));
    }
    let mut series: Vec<String> = Vec::new();
    for r in pts {
        let s = format!("{} {} {}", r.workload, r.transport, r.link);
        if !series.contains(&s) {
            series.push(s);
        }
    }
    for (i, s) in series.iter().enumerate() {
        let c = PALETTE[i % PALETTE.len()];
        let dots: Vec<(f64, f64)> = pts
            .iter()
            .filter(|r| format!("{} {} {}", r.workload, r.transport, r.link) == *s)
            .map(|r| (r.measured_s, r.modelled_s))
            .collect();
        chart
            .draw_series(dots.into_iter().map(|p| Circle::new(p, 4, c.filled())))?
            .label(s.clone())
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}
