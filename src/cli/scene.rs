//! `pvrsim scene DATA --field F -o scene.toml`: writes a fitted, commented
//! scene so nobody computes an eye position by hand. The fitting (camera
//! framing, the default transfer function) is [`crate::scene::fit`]'s,
//! reading the data [`crate::job::scene_fit`]'s; this file parses the
//! options, checks the output and writes the file.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::output::{prepare_output, OutputKind};
use super::validate::{Checks, Validate};
/// The scene-text check `demo` uses too (the fitting module's).
pub use crate::scene::fit::ensure_finite_toml;
use crate::scene::fit::{parse_view, FitSpec};

/// Options of `pvrsim scene`.
#[derive(Debug, Clone, Args)]
pub struct SceneArgs {
    /// Data file: a tetrahedral mesh (.vtk, .vtu, .pvtu, .inp) or a regular grid
    /// (.nhdr, .nrrd, .nii, .nii.gz, .vti, .fld).
    pub data: PathBuf,
    /// Output scene (TOML). Not overwritten without --force.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Point-data field to render (a vector field renders as its magnitude).
    /// May be left out when the data has one field (every grid but a VTI
    /// with several arrays).
    #[arg(long)]
    pub field: Option<String>,
    /// Where the camera is: a side (`+x`, `-x`, `+y`, `-y`, `+z`, `-z`: the
    /// camera on that side, looking at the centre) or `AZ,EL` in degrees
    /// (azimuth about +z from the -y side towards +x, elevation towards +z).
    #[arg(long, default_value = "-y", allow_hyphen_values = true)]
    pub view: String,
    /// Perspective projection with this vertical field of view (degrees, in
    /// (0, 180)); default: orthographic.
    #[arg(long, value_name = "DEG")]
    pub perspective: Option<f64>,
    /// Image size, WxH.
    #[arg(long, default_value = "512x512")]
    pub size: String,
    /// Overwrite an existing output file.
    #[arg(long)]
    pub force: bool,
}

/// Parses `WxH`.
pub fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| anyhow::anyhow!("--size {s}: expected WxH, e.g. 512x512"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| anyhow::anyhow!("--size {s}: width `{w}` is not a whole number"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| anyhow::anyhow!("--size {s}: height `{h}` is not a whole number"))?;
    anyhow::ensure!(
        w >= 1 && h >= 1,
        "--size {s}: both sides must be at least 1"
    );
    super::validate::image_size(Some(w), Some(h))?;
    Ok((w, h))
}

impl Validate for SceneArgs {
    type Parsed = ();

    fn validate(&self, _c: &mut Checks) -> anyhow::Result<()> {
        parse_size(&self.size)?;
        parse_view(&self.view)?;
        if let Some(f) = self.perspective {
            anyhow::ensure!(
                f.is_finite() && f > 0.0 && f < 180.0,
                "--perspective {f}: the field of view must be in (0, 180) degrees"
            );
        }
        Ok(())
    }
}

/// Runs `pvrsim scene`.
pub fn run(a: SceneArgs) -> anyhow::Result<()> {
    super::validate::apply(&a)?;
    anyhow::ensure!(
        a.force || !a.output.exists(),
        "-o {}: the file exists (--force overwrites it)",
        a.output.display()
    );
    prepare_output("-o", &a.output, OutputKind::Toml)?;
    let text = crate::job::scene_fit::fit_scene(&FitSpec {
        data: a.data.clone(),
        output: a.output.clone(),
        field: a.field.clone(),
        view: a.view.clone(),
        size: parse_size(&a.size)?,
        perspective: a.perspective,
    })?;
    std::fs::write(&a.output, &text)
        .with_context(|| format!("cannot write {}", a.output.display()))?;
    println!(
        "wrote {} (render it: pvrsim render {} -o out.png)",
        a.output.display(),
        a.output.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("300x200").unwrap(), (300, 200));
        assert!(parse_size("300").is_err());
        assert!(parse_size("0x10").is_err());
    }
}
