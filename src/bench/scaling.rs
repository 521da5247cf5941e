//! `pvrsim bench --scaling`: how load, projection, scan, compositing and
//! peak memory grow with the mesh. For each cell count the demo vessel is
//! generated once into a cache folder (`pvrsim demo --cells N --nodes 0`,
//! reused when present), then rendered by a child `pvrsim render` per image
//! size, one thread, exact, ERT off. Each child is reaped with `wait4`, so
//! every point's peak resident memory is its own. Writes `scaling.csv` and
//! log-log plots ([`super::scaling_plot`]); progress goes to stderr.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};

use super::scaling_plot::{self, PlotPoint};

/// What `pvrsim bench --scaling` runs.
#[derive(Debug, Clone)]
pub struct ScalingBench {
    /// Target cell counts (`pvrsim demo --cells`), ascending.
    pub cells: Vec<u64>,
    /// Points above this many cells are skipped (say so on stderr).
    pub max_cells: u64,
    /// Square image sizes in pixels (512 = 512x512).
    pub sizes: Vec<u32>,
    /// Render threads.
    pub threads: usize,
    /// Folder of generated meshes (`c<N>/demo.toml`), reused across runs.
    pub cache: PathBuf,
    /// Folder for `scaling.csv` and the plots.
    pub out: PathBuf,
}

/// One measured point (a row of `scaling.csv`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct ScalingRow {
    /// Tetrahedra in the generated mesh.
    pub cells: u64,
    /// Image width = height, pixels.
    pub image: u32,
    /// Render threads.
    pub threads: usize,
    /// Bytes of the mesh file (binary VTK legacy).
    pub file_bytes: u64,
    /// Wall time of `pvrsim demo` (generate, write, one small render); 0 if
    /// the mesh came from the cache (then `gen_peak_rss_bytes` is 0 too).
    pub gen_s: f64,
    /// Peak RSS of the generator process, bytes (0 if cached).
    pub gen_peak_rss_bytes: u64,
    /// Load phase of the render (`time_load_s`).
    pub load_s: f64,
    /// Projection phase (`time_project_s`).
    pub project_s: f64,
    /// Scan phase (`time_scan_s`).
    pub scan_s: f64,
    /// Compositing phase (`time_composite_s`).
    pub composite_s: f64,
    /// Whole render as the renderer reports it (`time_total_s`).
    pub total_s: f64,
    /// Wall time of the render child process (start to exit).
    pub process_s: f64,
    /// Peak RSS of the render child, bytes (`wait4` ru_maxrss).
    pub peak_rss_bytes: u64,
    /// `peak_rss_bytes / cells`.
    pub bytes_per_tet: f64,
}

/// The CSV header, in column order of [`ScalingRow`].
pub const CSV_HEADER: &str = "cells,image,threads,file_bytes,gen_s,gen_peak_rss_bytes,load_s,project_s,scan_s,composite_s,total_s,process_s,peak_rss_bytes,bytes_per_tet";

impl ScalingRow {
    fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:.6},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{:.2}",
            self.cells,
            self.image,
            self.threads,
            self.file_bytes,
            self.gen_s,
            self.gen_peak_rss_bytes,
            self.load_s,
            self.project_s,
            self.scan_s,
            self.composite_s,
            self.total_s,
            self.process_s,
            self.peak_rss_bytes,
            self.bytes_per_tet
        )
    }
}

/// Runs `cmd` to completion; returns (wall seconds, peak RSS bytes) of that
/// child alone, or an error naming `what` with its stderr tail.
pub(super) fn run_measured(mut cmd: Command, what: &str) -> anyhow::Result<(f64, u64)> {
    let t = Instant::now();
    let child = cmd
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .with_context(|| format!("{what}: cannot start"))?;
    let pid = child.id() as libc::pid_t;
    // Drain stderr on a thread so the child never blocks on a full pipe.
    let mut err = child.stderr.expect("stderr was piped");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut err, &mut s);
        s
    });
    let mut status: libc::c_int = 0;
    // SAFETY: an all-zero rusage is a valid value; wait4 only writes it.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: pid is our own un-reaped child; the pointers are valid.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut ru) };
    let secs = t.elapsed().as_secs_f64();
    let stderr = reader.join().unwrap_or_default();
    if r != pid {
        bail!("{what}: wait4 failed: {}", std::io::Error::last_os_error());
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        let tail: Vec<&str> = stderr.lines().rev().take(5).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        bail!("{what} failed (status {status}): {}", tail.join(" | "));
    }
    Ok((secs, ru.ru_maxrss.max(0) as u64 * 1024))
}

pub(super) fn read_stats(path: &Path) -> anyhow::Result<serde_json::Value> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("render stats {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("render stats {}", path.display()))
}

pub(super) fn stat(v: &serde_json::Value, key: &str, path: &Path) -> anyhow::Result<f64> {
    v.get(key)
        .and_then(|x| x.as_f64())
        .with_context(|| format!("render stats {}: no number `{key}`", path.display()))
}

/// Runs the benchmark; writes `scaling.csv` and the plots into `b.out`.
pub fn run(b: &ScalingBench) -> anyhow::Result<Vec<ScalingRow>> {
    if b.cells.is_empty() || b.sizes.is_empty() {
        bail!("--scaling needs at least one cell count (--scaling-cells) and one image size (--scaling-sizes)");
    }
    if b.sizes.contains(&0) || b.threads == 0 {
        bail!("--scaling-sizes and --scaling-threads must be > 0");
    }
    let exe = std::env::current_exe().context("cannot find the pvrsim executable")?;
    std::fs::create_dir_all(&b.cache)
        .with_context(|| format!("--scaling-cache {}", b.cache.display()))?;
    std::fs::create_dir_all(&b.out)
        .with_context(|| format!("--scaling-out {}", b.out.display()))?;
    let mut rows = Vec::new();
    for &n in &b.cells {
        if n > b.max_cells {
            eprintln!(
                "scaling: skipping {n} cells (above --max-cells {})",
                b.max_cells
            );
            continue;
        }
        let dir = b.cache.join(format!("c{n}"));
        let scene = dir.join("demo.toml");
        let mesh = dir.join("demo.vtk");
        let (mut gen_s, mut gen_rss) = (0.0, 0);
        if scene.is_file() && mesh.is_file() {
            eprintln!("scaling: {n} cells: reusing {}", dir.display());
        } else {
            eprintln!("scaling: {n} cells: generating into {}", dir.display());
            let mut cmd = Command::new(&exe);
            cmd.args([
                "demo",
                "--cells",
                &n.to_string(),
                "--nodes",
                "0",
                "--out-dir",
            ])
            .arg(&dir);
            (gen_s, gen_rss) = run_measured(cmd, &format!("pvrsim demo --cells {n}"))?;
            eprintln!(
                "scaling: {n} cells: generated in {gen_s:.1} s, peak RSS {} MB",
                gen_rss >> 20
            );
        }
        let file_bytes = std::fs::metadata(&mesh)
            .with_context(|| format!("{}", mesh.display()))?
            .len();
        for &s in &b.sizes {
            let stats = b.out.join(format!("stats-c{n}-{s}.json"));
            let png = b.out.join(format!("render-c{n}-{s}.png"));
            let mut cmd = Command::new(&exe);
            cmd.arg("render")
                .arg(&scene)
                .arg("-o")
                .arg(&png)
                .args(["--threads", &b.threads.to_string(), "--ert", "1"])
                .args(["--width", &s.to_string(), "--height", &s.to_string()])
                .arg("--stats")
                .arg(&stats);
            let (process_s, rss) = run_measured(cmd, &format!("pvrsim render ({n} cells, {s}^2)"))?;
            let v = read_stats(&stats)?;
            let cells = stat(&v, "cells_total", &stats)? as u64;
            let row = ScalingRow {
                cells,
                image: s,
                threads: b.threads,
                file_bytes,
                gen_s,
                gen_peak_rss_bytes: gen_rss,
                load_s: stat(&v, "time_load_s", &stats)?,
                project_s: stat(&v, "time_project_s", &stats)?,
                scan_s: stat(&v, "time_scan_s", &stats)?,
                composite_s: stat(&v, "time_composite_s", &stats)?,
                total_s: stat(&v, "time_total_s", &stats)?,
                process_s,
                peak_rss_bytes: rss,
                bytes_per_tet: rss as f64 / cells.max(1) as f64,
            };
            eprintln!(
                "scaling: {} cells, {s}^2: load {:.3} s, project {:.3} s, scan {:.3} s, composite {:.3} s, peak RSS {} MB ({:.1} B/tet)",
                row.cells, row.load_s, row.project_s, row.scan_s, row.composite_s, rss >> 20, row.bytes_per_tet
            );
            rows.push(row);
        }
    }
    let csv = b.out.join("scaling.csv");
    let mut text = String::from(CSV_HEADER);
    text.push('\n');
    for r in &rows {
        text.push_str(&r.csv());
        text.push('\n');
    }
    std::fs::write(&csv, text).with_context(|| format!("{}", csv.display()))?;
    println!("wrote {}", csv.display());
    if !rows.is_empty() {
        let pts: Vec<PlotPoint> = rows
            .iter()
            .map(|r| PlotPoint {
                cells: r.cells,
                image: r.image,
                load_s: r.load_s,
                project_s: r.project_s,
                scan_s: r.scan_s,
                composite_s: r.composite_s,
                bytes_per_tet: r.bytes_per_tet,
            })
            .collect();
        for p in scaling_plot::draw(&pts, &b.out)? {
            println!("wrote {}", p.display());
        }
    }
    Ok(rows)
}
