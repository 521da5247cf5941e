//! The per-node Gantt chart (`--timeline run.png`): one row per rank
//! (nodes, then the manager), time on x, spans coloured by activity.

use std::path::Path;

use plotters::prelude::*;

use crate::net::{SimTrace, TraceKind};

const ROW_H: u32 = 22;

/// The colour of a span kind (`None`: not drawn).
pub fn colour(kind: TraceKind) -> Option<RGBColor> {
    Some(match kind {
        TraceKind::Scan => RGBColor(31, 119, 180),
        TraceKind::Share => RGBColor(44, 160, 44),
        TraceKind::Steal => RGBColor(255, 127, 14),
        TraceKind::Idle => RGBColor(225, 225, 225),
        TraceKind::Composite => RGBColor(148, 103, 189),
        TraceKind::Compute => RGBColor(127, 127, 127),
        TraceKind::Send | TraceKind::Recv => return None,
    })
}

/// The span kinds the chart draws and its legend names, in drawing order:
/// only those that occur in `trace` (a legend entry with no span, such as
/// `compute` in a cluster run, would only confuse).
pub fn kinds_shown(trace: &SimTrace) -> Vec<TraceKind> {
    [
        TraceKind::Idle,
        TraceKind::Scan,
        TraceKind::Share,
        TraceKind::Steal,
        TraceKind::Composite,
        TraceKind::Compute,
    ]
    .into_iter()
    .filter(|&k| colour(k).is_some() && trace.events.iter().any(|e| e.kind == k && e.end > e.start))
    .collect()
}

/// Draws the chart of `trace` (`nodes` nodes; rank `nodes` is the manager)
/// into a PNG at `path`. The legend names only the kinds that occur.
pub fn draw(trace: &SimTrace, nodes: usize, path: &Path) -> anyhow::Result<()> {
    crate::text::register_fonts();
    let ranks = trace
        .events
        .iter()
        .map(|e| e.node.index() + 1)
        .max()
        .unwrap_or(nodes)
        .max(nodes);
    let row_h = if ranks > 40 {
        (880 / ranks as u32).max(2)
    } else {
        ROW_H
    };
    let height = (ranks as u32 * row_h + 130).max(300);
    let end = trace
        .events
        .iter()
        .map(|e| e.end)
        .fold(0.0f64, f64::max)
        .max(1e-9);
    let root = BitMapBackend::new(path, (1200, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("cluster timeline: {nodes} nodes + manager (rank {nodes})"),
            ("sans-serif", 20),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..end * 1.16, -0.5..ranks as f64 - 0.5)?;
    let label_every = (ranks / 20).max(1);
    chart
        .configure_mesh()
        .disable_y_mesh()
        .x_desc("time (s); phase 1 (scan, ERT sharing, DLB), then phase 2 (compositing)")
        .y_labels(ranks.min(40) + 1)
        .y_label_formatter(&|y| {
            let r = ranks as i64 - 1 - y.round() as i64;
            if (y - y.round()).abs() > 1e-6 || r < 0 {
                return String::new();
            }
            let r = r as usize;
            if r < nodes && r.is_multiple_of(label_every) {
                format!("node {r}")
            } else if r == nodes {
                "manager".into()
            } else {
                String::new()
            }
        })
        .draw()?;
    for kind in kinds_shown(trace) {
        let Some(c) = colour(kind) else { continue };
        let rects = trace
            .events
            .iter()
            .filter(|e| e.kind == kind && e.end > e.start)
            .map(|e| {
                let c_y = (ranks - 1 - e.node.index()) as f64;
                Rectangle::new([(e.start, c_y + 0.4), (e.end, c_y - 0.4)], c.filled())
            });
        chart
            .draw_series(rects)?
            .label(kind.name())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], c.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}
