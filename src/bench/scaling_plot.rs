//! Log-log plots of `pvrsim bench --scaling`: phase times against cells and
//! peak memory per tetrahedron against cells, one line per image size.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

/// One measured point as the plots need it.
#[derive(Debug, Clone, Copy)]
pub struct PlotPoint {
    /// Tetrahedra.
    pub cells: u64,
    /// Image width = height, pixels.
    pub image: u32,
    /// Load phase, s.
    pub load_s: f64,
    /// Projection phase, s.
    pub project_s: f64,
    /// Scan phase, s.
    pub scan_s: f64,
    /// Compositing phase, s.
    pub composite_s: f64,
    /// Render peak RSS per tetrahedron, bytes.
    pub bytes_per_tet: f64,
}

type Series = (String, Vec<(f64, f64)>);
/// A named phase and how to read its time from a point.
type Phase = (&'static str, fn(&PlotPoint) -> f64);

/// Draws `scaling-times.png` and `scaling-memory.png` into `out`; returns
/// their paths. Non-positive values (e.g. a 0 s composite) are left out,
/// as a log axis cannot show them.
pub fn draw(rows: &[PlotPoint], out: &Path) -> anyhow::Result<Vec<PathBuf>> {
    crate::text::register_fonts();
    let mut sizes: Vec<u32> = rows.iter().map(|r| r.image).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let phase: [Phase; 4] = [
        ("load", |r| r.load_s),
        ("project", |r| r.project_s),
        ("scan", |r| r.scan_s),
        ("composite", |r| r.composite_s),
    ];
    let mut times: Vec<Series> = Vec::new();
    let mut mem: Vec<Series> = Vec::new();
    for &s in &sizes {
        let at: Vec<&PlotPoint> = rows.iter().filter(|r| r.image == s).collect();
        for (name, f) in phase {
            times.push((
                format!("{name} {s}^2"),
                at.iter().map(|r| (r.cells as f64, f(r))).collect(),
            ));
        }
        mem.push((
            format!("render peak RSS / tet, {s}^2"),
            at.iter()
                .map(|r| (r.cells as f64, r.bytes_per_tet))
                .collect(),
        ));
    }
    let a = out.join("scaling-times.png");
    chart(
        &a,
        "Render phases against mesh size (1 thread, exact, ERT off)",
        "time (s)",
        &times,
    )?;
    let b = out.join("scaling-memory.png");
    chart(
        &b,
        "Peak resident memory per tetrahedron",
        "bytes per tet",
        &mem,
    )?;
    Ok(vec![a, b])
}

fn bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    if !lo.is_finite() || hi <= 0.0 {
        return (0.1, 10.0);
    }
    (lo / 1.5, hi * 1.5)
}

fn chart(path: &Path, title: &str, y_desc: &str, series: &[Series]) -> anyhow::Result<()> {
    let series: Vec<Series> = series
        .iter()
        .map(|(n, p)| {
            let p = p
                .iter()
                .copied()
                .filter(|&(x, y)| x > 0.0 && y > 0.0 && y.is_finite());
            (n.clone(), p.collect())
        })
        .collect();
    let (x0, x1) = bounds(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)));
    let (y0, y1) = bounds(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)));
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut c = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    c.configure_mesh()
        .x_desc("tetrahedra (log)")
        .y_desc(format!("{y_desc} (log)"))
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .draw()?;
    for (k, (name, pts)) in series.iter().enumerate() {
        if pts.is_empty() {
            continue;
        }
        let col = Palette99::pick(k).to_rgba();
        c.draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col));
        c.draw_series(pts.iter().map(|&p| Circle::new(p, 3, col.filled())))?;
    }
    c.configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()?;
    root.present()?;
    Ok(())
}
