//! `pvrsim splat-experiments`: the measurements of
//! `docs/experiments/splatting.md` (issue 11), printed as markdown tables:
//! the 45° sweep (image change between neighbouring view angles, axis vs
//! DDA, plotted), time against fill rate (Tables 2-3's shape) on a
//! generated hydrogen (KVS, generate::hydrogen) 128^3 grid and on the MNI152 template resampled
//! to 256^3, and the images against the grid reference.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use clap::Args;
use plotters::prelude::*;

use super::orderings::thread_cpu_s;
use crate::data::volume::generate::hydrogen;
use crate::data::{Volume, Voxels};
use crate::image::Image;
use crate::render::grid_reference;
use crate::render::splat::order::Order;
use crate::render::splat::{render_splat, SplatOptions};
use crate::render::VolumeInput;
use crate::scene::camera::{Camera, Projection};
use crate::scene::{DataSpec, ImageSpec, Scene, TransferFunction};

/// Options of `pvrsim splat-experiments`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Where the plot goes.
    #[arg(long, default_value = "docs/experiments")]
    pub out: PathBuf,
    /// The shared data folder (for the 256^3 MNI152 grid; skipped, with a
    /// message, when absent).
    #[arg(long, default_value = "../shared/data")]
    pub data_dir: PathBuf,
    /// Only these parts (comma-separated): sweep, fill, fill256, reference.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sweep,fill,fill256,reference"
    )]
    pub parts: Vec<String>,
}

/// An orthographic scene looking at the volume's centre from azimuth `az`
/// and elevation `el` (degrees), whole box in view.
pub(super) fn scene_for(vol: &Volume, az: f64, el: f64, size: u32, tf: TransferFunction) -> Scene {
    let (lo, hi) = vol.bounds();
    let c: [f64; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
    let diag = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    let (az, el) = (az.to_radians(), el.to_radians());
    let d = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
    Scene {
        data: DataSpec {
            path: PathBuf::from("generated"),
            field: vol.field.clone(),
            range: Some([0.0, 255.0]),
        },
        camera: Camera {
            eye: std::array::from_fn(|a| c[a] + 2.0 * diag * d[a]),
            target: c,
            up: [0.0, 0.0, 1.0],
            projection: Projection::Orthographic {
                height: diag * 1.02,
            },
        },
        image: ImageSpec {
            width: size,
            height: size,
            background: [0.0; 3],
        },
        transfer: tf,
    }
}

/// Opacity 0 below `threshold` (normalised), then a warm ramp; per voxel
/// spacing `unit`.
pub(super) fn ramp_tf(threshold: f64, unit: f64) -> TransferFunction {
    TransferFunction::from_rows(
        &[
            [0.0, 0.0, 0.0, 0.0, 0.0],
            [threshold, 0.2, 0.3, 1.0, 0.0],
            [threshold + 1e-3, 0.2, 0.3, 1.0, 0.03],
            [0.6, 1.0, 0.6, 0.2, 0.15],
            [1.0, 1.0, 1.0, 0.9, 0.5],
        ],
        unit,
    )
}

fn input(vol: &Arc<Volume>, scene: Scene) -> VolumeInput {
    VolumeInput::new(scene, vol.clone()).expect("valid input")
}

fn rmse(a: &Image, b: &Image) -> f64 {
    a.error_against(b).rmse
}

/// Runs the experiments.
pub fn run(a: ExperimentArgs) -> anyhow::Result<()> {
    let part = |p: &str| a.parts.iter().any(|x| x == p);
    if part("sweep") {
        sweep(&a.out)?;
    }
    if part("fill") {
        let vol = Arc::new(hydrogen(128));
        println!(
            "\n## Time against fill rate, hydrogen (KVS, generate::hydrogen) 128^3, 512^2, azimuth 30, elevation 25\n"
        );
        fill_table(
            &vol,
            &[0.01, 0.02, 0.04, 0.08, 0.135, 0.2, 0.33],
            512,
            vol.spacing[0],
            3,
        )?;
    }
    if part("fill256") {
        let path = a.data_dir.join("mni152_t1.nhdr");
        if !path.exists() {
            println!("\nskipped fill256: {} is absent", path.display());
        } else {
            let src = crate::data::io::read_volume(&path, "")?;
            let vol = Arc::new(resample(&src, 256));
            println!("\n## Time against fill rate, MNI152 resampled to 256^3, 512^2\n");
            fill_table(
                &vol,
                &[0.0144, 0.0423, 0.123, 0.257],
                512,
                vol.spacing[0],
                1,
            )?;
        }
    }
    if part("reference") {
        reference()?;
    }
    Ok(())
}

/// Trilinear resampling of `src` to `n^3` samples over the same box.
pub fn resample(src: &Volume, n: u64) -> Volume {
    let (lo, hi) = src.bounds();
    let sp: [f64; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) / (n - 1) as f64);
    let mut v = Vec::with_capacity((n * n * n) as usize);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let g = [i as f64, j as f64, k as f64];
                let sg: [f64; 3] = std::array::from_fn(|a| {
                    (g[a] * sp[a] / src.spacing[a]).min((src.dims[a] - 1) as f64)
                });
                v.push(
                    src.trilinear_grid(sg)
                        .unwrap_or(0.0)
                        .round()
                        .clamp(0.0, 255.0) as u8,
                );
            }
        }
    }
    Volume::new(Path::new("resampled"), [n; 3], sp, lo, "t1", Voxels::U8(v))
        .expect("resampled volume is valid")
}

/// The normalised threshold above which about `fill` of the (u8) voxels lie.
pub(super) fn threshold_for(vol: &Volume, fill: f64) -> f64 {
    let Voxels::U8(v) = &vol.voxels else {
        unreachable!("the experiments use u8 volumes")
    };
    let mut hist = [0u64; 256];
    v.iter().for_each(|&x| hist[x as usize] += 1);
    let want = (fill * v.len() as f64) as u64;
    let mut above = 0u64;
    for t in (0..256).rev() {
        if above + hist[t] > want {
            // Voxels with value > t are kept (opacity 0 at and below t).
            return t as f64 / 255.0;
        }
        above += hist[t];
    }
    0.0
}

/// Time against fill rate: for each target fill rate, a threshold from the
/// histogram (the paper's fill rates), then dda / quicksort / radix / axis
/// frames (median of 3, ms of ordering + projection and of splatting).
fn fill_table(
    vol: &Arc<Volume>,
    fills: &[f64],
    size: u32,
    unit: f64,
    repeats: usize,
) -> anyhow::Result<()> {
    let thresholds: Vec<f64> = fills
        .iter()
        .map(|&f| threshold_for(vol, f) + 0.5 / 255.0)
        .collect();
    println!("| fill rate | drawn | dda CPU ms (order + splat) | quicksort CPU ms (order + splat) | radix CPU ms | axis CPU ms | dda fps | quicksort fps |");
    println!("|---|---|---|---|---|---|---|---|");
    for &t in &thresholds {
        let inp = input(vol, scene_for(vol, 30.0, 25.0, size, ramp_tf(t, unit)));
        let mut row = Vec::new();
        let mut fill = 0.0;
        let mut drawn = 0;
        for order in [Order::Dda, Order::Quicksort, Order::Radix, Order::Axis] {
            // Median of `repeats` frames, one thread, thread CPU time (the
            // machine is shared: wall clock swings with others' load).
            let mut ms: Vec<(f64, f64)> = (0..repeats)
                .map(|_| {
                    let opts = SplatOptions {
                        order,
                        ..Default::default()
                    };
                    super::with_threads(1, || {
                        let t0 = thread_cpu_s();
                        let (_, s) = render_splat(&inp, &opts).expect("render");
                        let total = (thread_cpu_s() - t0) * 1e3;
                        // Split the CPU total by the wall-clock shares.
                        let f = s.order_ms / (s.order_ms + s.splat_ms);
                        fill = s.fill_rate;
                        drawn = s.voxels_drawn;
                        (total, total * f)
                    })
                    .expect("thread pool")
                })
                .collect();
            ms.sort_by(|x, y| x.0.total_cmp(&y.0));
            row.push(ms[ms.len() / 2]);
        }
        println!(
            "| {:.4} | {} | {:.0} ({:.0} + {:.0}) | {:.0} ({:.0} + {:.0}) | {:.0} | {:.0} | {:.1} | {:.1} |",
            fill,
            drawn,
            row[0].0,
            row[0].1,
            row[0].0 - row[0].1,
            row[1].0,
            row[1].1,
            row[1].0 - row[1].1,
            row[2].0,
            row[3].0,
            1e3 / row[0].0,
            1e3 / row[1].0
        );
    }
    Ok(())
}

/// The 45° sweep: azimuth 35..55° in 1° steps at elevation 20°; RMSE
/// between neighbouring angles for the axis and the DDA orders; plot.
fn sweep(out: &Path) -> anyhow::Result<()> {
    let vol = Arc::new(hydrogen(64));
    let angles: Vec<f64> = (0..=40).map(|k| 35.0 + 0.5 * k as f64).collect();
    let mut series: Vec<(Order, Vec<f64>)> = Vec::new();
    println!(
        "\n## 45-degree sweep, hydrogen (KVS, generate::hydrogen) 64^3, 256^2, elevation 20\n"
    );
    for order in [Order::Axis, Order::Dda, Order::Quicksort] {
        let imgs: Vec<Image> = angles
            .iter()
            .map(|&az| {
                let inp = input(
                    &vol,
                    scene_for(&vol, az, 20.0, 256, ramp_tf(0.3, vol.spacing[0])),
                );
                render_splat(
                    &inp,
                    &SplatOptions {
                        order,
                        ..Default::default()
                    },
                )
                .expect("render")
                .0
            })
            .collect();
        let d: Vec<f64> = imgs.windows(2).map(|w| rmse(&w[0], &w[1])).collect();
        series.push((order, d));
    }
    println!("| azimuth step | axis RMSE | dda RMSE | quicksort RMSE |");
    println!("|---|---|---|---|");
    for (k, w) in angles.windows(2).enumerate() {
        println!(
            "| {:.1}-{:.1} | {:.3} | {:.3} | {:.3} |",
            w[0], w[1], series[0].1[k], series[1].1[k], series[2].1[k]
        );
    }
    std::fs::create_dir_all(out)?;
    let png = out.join("splatting-45deg.png");
    crate::text::register_fonts();
    let ymax = series
        .iter()
        .flat_map(|s| s.1.iter().cloned())
        .fold(0.0, f64::max)
        * 1.1;
    let root = BitMapBackend::new(&png, (800, 450)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Image change between views 0.5 deg apart",
            ("sans-serif", 22),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(35.0..55.0, 0.0..ymax)?;
    chart
        .configure_mesh()
        .x_desc("azimuth (deg), midpoint of the step")
        .y_desc("RMSE between neighbours (1/255)")
        .draw()?;
    let colours = [RED, BLUE, GREEN];
    for ((order, d), col) in series.iter().zip(colours) {
        let pts: Vec<(f64, f64)> = angles
            .windows(2)
            .zip(d)
            .map(|(w, &v)| (0.5 * (w[0] + w[1]), v))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))?
            .label(order.name())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, col.filled())))?;
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()?;
    root.present()?;
    println!("\nwrote {}", png.display());
    Ok(())
}

/// Splat images against the grid reference (hydrogen (KVS, generate::hydrogen) 64^3, 160^2).
fn reference() -> anyhow::Result<()> {
    let vol = Arc::new(hydrogen(64));
    println!("\n## Against the grid reference, hydrogen (KVS, generate::hydrogen) 64^3, 160^2\n");
    println!("| view | order | max-abs (1/255) | RMSE (1/255) | vs quicksort max-abs | vs quicksort RMSE |");
    println!("|---|---|---|---|---|---|");
    for (az, el) in [(30.0, 25.0), (45.0, 20.0)] {
        let inp = input(
            &vol,
            scene_for(&vol, az, el, 160, ramp_tf(0.3, vol.spacing[0])),
        );
        let (r, _) = grid_reference::render(&inp, &Default::default());
        let imgs: Vec<(Order, Image)> = Order::ALL
            .iter()
            .map(|&o| {
                let i = render_splat(
                    &inp,
                    &SplatOptions {
                        order: o,
                        ..Default::default()
                    },
                )
                .expect("render")
                .0;
                (o, i)
            })
            .collect();
        let qs = imgs[2].1.clone();
        // The previous footprint path (conic + exponentials per pixel) and
        // the 8-phase table, DDA order, beside the default.
        let variant = |incremental, table_phases| {
            render_splat(
                &inp,
                &SplatOptions {
                    order: Order::Dda,
                    incremental,
                    table_phases,
                    ..Default::default()
                },
            )
            .expect("render")
            .0
        };
        let extra = [
            ("dda, exact footprints", variant(false, 0)),
            ("dda, 8-phase table", variant(true, 8)),
        ];
        let named = imgs
            .iter()
            .map(|(o, i)| (o.name(), i))
            .chain(extra.iter().map(|(n, i)| (*n, i)));
        for (o, i) in named {
            let e = i.error_against(&r);
            let q = i.error_against(&qs);
            println!(
                "| az {az} el {el} | {o} | {:.2} | {:.3} | {:.3} | {:.4} |",
                e.max_abs, e.rmse, q.max_abs, q.rmse
            );
        }
        let tag = format!("az{az:.0}");
        let dda = &imgs[1].1;
        Image::side_by_side(&[dda, &r, &Image::difference(dda, &r, 8.0)], 4).save_png(
            Path::new(&format!(
                "docs/experiments/splatting-vs-reference-{tag}.png"
            )),
        )?;
    }
    Ok(())
}
