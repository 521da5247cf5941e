//! `pvrsim bench --adaptive`: the shape of the paper's Table 3 (adaptive
//! sampling by block count: size ratio 縮小率 and preprocessing time) on
//! our grids, plus what the paper did not measure: the frame time and the
//! image error the reduction causes, against full-resolution `slice3d` and
//! against the grid reference, under the scene's transfer function and
//! under the paper's (grey, opacity equal to the normalised voxel value).

use std::path::Path;
use std::sync::Arc;

use crate::render::adaptive::{self, AdaptiveOptions};
use crate::render::slice3d::{self, Slice3dOptions};
use crate::render::{grid_reference, VolumeInput};
use crate::scene::{Scene, TransferFunction};

/// Scenes of `--adaptive` (file names in the data folder); `ml64` is the
/// generated Marschner–Lobb grid (no data needed).
pub const ADAPTIVE_SCENES: &str = "mni152-view.toml,frog-view.toml,ml64";

/// One (scene, transfer function, block count) measurement.
#[derive(Debug, serde::Serialize)]
pub struct AdaptiveRow {
    /// Scene.
    pub scene: String,
    /// `scene` (the scene's TF) or `paper` (grey, opacity = value).
    pub transfer: String,
    /// Samples per axis.
    pub dims: [u64; 3],
    /// Blocks per axis `b`.
    pub blocks_per_axis: u64,
    /// Tolerance `τ`.
    pub tolerance: f64,
    /// Size ratio (縮小率), percent.
    pub size_ratio_pct: f64,
    /// Preprocessing seconds.
    pub build_s: f64,
    /// Adaptive frame seconds (one frame, all threads).
    pub frame_s: f64,
    /// Full-resolution slice3d frame seconds, same options.
    pub frame_full_s: f64,
    /// Blocks per level.
    pub levels: Vec<u64>,
    /// Scalar RMS error over all samples, percent of `R`.
    pub scalar_rms_pct: f64,
    /// Image max-abs against full-resolution slice3d, 1/255.
    pub max_abs_vs_full: f64,
    /// Image RMSE against full-resolution slice3d, 1/255.
    pub rmse_vs_full: f64,
    /// Image max-abs against the grid reference, 1/255.
    pub max_abs_vs_ref: f64,
    /// Image RMSE against the grid reference, 1/255.
    pub rmse_vs_ref: f64,
    /// slice3d (full) against the reference, max-abs 1/255.
    pub full_max_abs_vs_ref: f64,
    /// slice3d (full) against the reference, RMSE 1/255.
    pub full_rmse_vs_ref: f64,
}

/// The paper's transfer function: grey, opacity equal to the normalised
/// voxel value (per unit distance of one sample spacing).
fn paper_tf(unit_distance: f64) -> TransferFunction {
    TransferFunction::from_rows(
        &[[0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0, 1.0]],
        unit_distance,
    )
}

fn load(data_dir: &Path, name: &str) -> anyhow::Result<Option<VolumeInput>> {
    if name == "ml64" {
        let dir =
            std::env::temp_dir().join(format!("pvrsim-bench-adaptive-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let v = crate::data::volume::generate::marschner_lobb(64);
        let path = dir.join("ml64.nrrd");
        crate::data::io::volume::write_nrrd(&v, &path, false, "bench --adaptive")?;
        let toml = crate::data::volume::scene::marschner_lobb_scene("ml64.nrrd", &v);
        let sp = dir.join("ml64.toml");
        std::fs::write(&sp, toml)?;
        let scene = Scene::load(&sp)?;
        let mut sc = scene;
        sc.image.width = 256;
        sc.image.height = 256;
        return Ok(Some(VolumeInput::new(sc, Arc::new(v))?));
    }
    let path = data_dir.join(name);
    if !path.exists() {
        println!("skipping {name}: {} not found", path.display());
        return Ok(None);
    }
    let scene = Scene::load(&path)?;
    let vol = crate::data::io::read_volume(&scene.data.path, &scene.data.field)?;
    Ok(Some(VolumeInput::new(scene, Arc::new(vol))?))
}

/// Runs the sweep over `blocks` (per axis) at tolerance `tol`.
pub fn run(
    data_dir: &Path,
    scenes: &[String],
    blocks: &[u64],
    tol: f64,
) -> anyhow::Result<Vec<AdaptiveRow>> {
    let opts = Slice3dOptions::default();
    let mut rows = Vec::new();
    println!(
        "{:<22} {:<6} {:>4} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9} {:>9} {:>9}",
        "scene",
        "tf",
        "b",
        "ratio%",
        "build_s",
        "frame_s",
        "scal%R",
        "max|full",
        "rms|full",
        "max|ref",
        "rms|ref"
    );
    for name in scenes {
        let Some(base) = load(data_dir, name)? else {
            continue;
        };
        for tf_name in ["scene", "paper"] {
            let mut input = base.clone();
            if tf_name == "paper" {
                let sp = input.volume.spacing;
                input.scene.transfer = paper_tf(sp[0].min(sp[1]).min(sp[2]));
            }
            let (full, fst) = slice3d::render(&input, &opts)?;
            let (reference, _) = grid_reference::render(&input, &Default::default());
            let fe = full.error_against(&reference);
            for &b in blocks {
                let a = AdaptiveOptions {
                    blocks: b,
                    tolerance: tol,
                };
                let (img, st) = adaptive::render(&input, &opts, &a)?;
                let ef = img.error_against(&full);
                let er = img.error_against(&reference);
                let s = &st.adaptive;
                let row = AdaptiveRow {
                    scene: name.clone(),
                    transfer: tf_name.into(),
                    dims: input.volume.dims,
                    blocks_per_axis: b,
                    tolerance: tol,
                    size_ratio_pct: 100.0 * s.size_ratio,
                    build_s: s.build_s,
                    frame_s: st.slice.time_render_s,
                    frame_full_s: fst.time_render_s,
                    levels: s.levels.clone(),
                    scalar_rms_pct: 100.0 * s.rms_error_rel,
                    max_abs_vs_full: ef.max_abs,
                    rmse_vs_full: ef.rmse,
                    max_abs_vs_ref: er.max_abs,
                    rmse_vs_ref: er.rmse,
                    full_max_abs_vs_ref: fe.max_abs,
                    full_rmse_vs_ref: fe.rmse,
                };
                println!(
                    "{:<22} {:<6} {:>4} {:>8.1} {:>8.3} {:>8.3} {:>8.3} {:>9.2} {:>9.3} {:>9.2} {:>9.3}",
                    row.scene,
                    row.transfer,
                    b,
                    row.size_ratio_pct,
                    row.build_s,
                    row.frame_s,
                    row.scalar_rms_pct,
                    row.max_abs_vs_full,
                    row.rmse_vs_full,
                    row.max_abs_vs_ref,
                    row.rmse_vs_ref
                );
                rows.push(row);
            }
            println!(
                "{:<22} {:<6} full slice3d: frame {:.3} s, vs reference max-abs {:.2}/255 RMSE {:.3}/255",
                name, tf_name, fst.time_render_s, fe.max_abs, fe.rmse
            );
        }
    }
    Ok(rows)
}
