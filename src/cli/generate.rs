//! `pvrsim generate`: test volumes of any size, written as attached NRRD
//! with a matching scene `.toml` beside them (same stem).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};

use crate::data::io::volume::write_nrrd;
use crate::data::volume::generate::{self, Filter};
use crate::data::volume::scene::{
    hydrogen_scene, marschner_lobb_scene, volume_scene_toml, VolumeSceneSpec,
};
use crate::data::Volume;

/// What to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Kind {
    /// The splatting paper's analytic hydrogen atom (KVS), u8, over a 32-unit cube.
    Hydrogen,
    /// The Marschner-Lobb test signal (f_M = 6, alpha = 0.25) on [-1,1]^3, f32.
    MarschnerLobb,
    /// An existing grid (--input) resampled to --size over the same box.
    Resample,
    /// A tetrahedral mesh's field sampled on a grid over its bounding box
    /// (--input: a mesh scene .toml, whose camera and transfer function the
    /// new scene keeps, or a mesh with --field); --size N = samples along
    /// the longest axis.
    MeshField,
    /// A copy of a mesh (--input, any mesh format) with its vertices and
    /// cells in a random order (fixed seed): the worst order a mesher can
    /// write, for measuring the load path's renumbering. -o OUT.vtk
    /// (binary legacy VTK).
    Permuted,
    /// Stand-in for the paper's Engine, 256x256x128 u8: --input resampled
    /// (e.g. ../shared/data/mni152_t1.nii.gz), the paper's TF (opacity = value).
    PaperEngine,
    /// Stand-in for Bonsai, 256^3 u8 (e.g. from colin27-brain.nii.gz).
    PaperBonsai,
    /// Stand-in for Chest, 512^3 u8 (e.g. from colin27-brain.nii.gz).
    PaperChest,
    /// Stand-in for Tree, 512x512x1024 u8 (256 MiB; e.g. from
    /// colin27-brain.nii.gz stretched along z: no shared grid has its shape).
    PaperTree,
}

impl Kind {
    /// The paper's size of a `paper-*` preset.
    pub fn paper_size(self) -> Option<[u64; 3]> {
        match self {
            Kind::PaperEngine => Some([256, 256, 128]),
            Kind::PaperBonsai => Some([256, 256, 256]),
            Kind::PaperChest => Some([512, 512, 512]),
            Kind::PaperTree => Some([512, 512, 1024]),
            _ => None,
        }
    }
}

/// Resampling filter for `generate resample`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FilterArg {
    /// The trilinear field at the new sample positions.
    Trilinear,
    /// Mean of the source samples within half a new spacing (for downsampling).
    Box,
}

impl From<FilterArg> for Filter {
    fn from(f: FilterArg) -> Filter {
        match f {
            FilterArg::Trilinear => Filter::Trilinear,
            FilterArg::Box => Filter::Box,
        }
    }
}

/// Options of `pvrsim generate`.
#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// What to generate.
    #[arg(value_enum)]
    pub kind: Kind,
    /// Samples per axis: N (a cube) or NxNxN.
    #[arg(long, default_value = "64")]
    pub size: String,
    /// Output volume (.nrrd); the scene goes beside it with the extension
    /// .toml (`permuted`: the mesh, .vtk).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Source grid for `resample` (.nrrd, .nhdr, .nii, .nii.gz, .vti, .fld).
    #[arg(long)]
    pub input: Option<PathBuf>,
    /// Resampling filter.
    #[arg(long, value_enum, default_value_t = FilterArg::Trilinear)]
    pub filter: FilterArg,
    /// Field of a mesh given as --input to `mesh-field` (default: the
    /// scene's field, or the mesh's only field).
    #[arg(long)]
    pub field: Option<String>,
    /// Compress the samples with gzip (NRRD `encoding: gzip`).
    #[arg(long)]
    pub gzip: bool,
    /// Overwrite OUTPUT and its .toml if they exist.
    #[arg(long)]
    pub force: bool,
}

/// Parses `N` or `NxNxN` (each >= 2).
pub fn parse_size(s: &str) -> anyhow::Result<[u64; 3]> {
    let parts: Vec<&str> = s.split(['x', 'X']).collect();
    let nums: Option<Vec<u64>> = parts.iter().map(|p| p.trim().parse().ok()).collect();
    match nums.as_deref() {
        Some(&[n]) if n >= 2 => Ok([n; 3]),
        Some(&[a, b, c]) if a >= 2 && b >= 2 && c >= 2 => Ok([a, b, c]),
        _ => bail!("--size {s:?}: expected N or NxNxN with every N >= 2"),
    }
}

/// `--output` must name an attached NRRD file.
pub fn check_output(a: &GenerateArgs) -> anyhow::Result<()> {
    let ext = a.output.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !ext.eq_ignore_ascii_case("nrrd") {
        bail!(
            "--output {}: the generator writes attached NRRD; name the file *.nrrd",
            a.output.display()
        );
    }
    for p in [a.output.clone(), a.output.with_extension("toml")] {
        anyhow::ensure!(
            a.force || !p.exists(),
            "-o {}: {} exists (--force overwrites it and its .toml)",
            a.output.display(),
            p.display()
        );
    }
    // The folder (one missing level is created, and said) and writability,
    // before any work; the scene goes beside the volume.
    crate::job::output::prepare_output("-o", &a.output, crate::job::output::OutputKind::Nrrd)?;
    Ok(())
}

/// Runs `pvrsim generate` (but `mesh-field`: [`super::generate_mesh::run`]).
pub fn run(a: GenerateArgs) -> anyhow::Result<()> {
    check_output(&a)?;
    if let Some(size) = a.kind.paper_size() {
        return paper(&a, size);
    }
    if a.field.is_some() && a.kind != Kind::MeshField {
        bail!("--field is only used by `generate mesh-field`");
    }
    anyhow::ensure!(
        !matches!(a.kind, Kind::MeshField | Kind::Permuted),
        "internal error: `generate mesh-field` and `permuted` run in generate_mesh"
    );
    let size = parse_size(&a.size)?;
    crate::budget::volume("--size", size, 4)?;
    if a.input.is_some() && a.kind != Kind::Resample {
        bail!("--input is only used by `generate resample`, `mesh-field` and `paper-*`");
    }
    let cube = |what: &str| -> anyhow::Result<u64> {
        if size[0] == size[1] && size[1] == size[2] {
            Ok(size[0])
        } else {
            bail!("{what} is generated on a cube: give --size N")
        }
    };
    let t = std::time::Instant::now();
    let name = file_name(&a.output)?;
    let (vol, scene, comment) = match a.kind {
        Kind::Hydrogen => {
            let v = generate::hydrogen(cube("hydrogen")?);
            let s = hydrogen_scene(&name, &v);
            (
                v,
                s,
                "pvrsim generate hydrogen (KVS HydrogenVolumeData formula)".to_string(),
            )
        }
        Kind::MarschnerLobb => {
            let v = generate::marschner_lobb(cube("marschner-lobb")?);
            let s = marschner_lobb_scene(&name, &v);
            (
                v,
                s,
                "pvrsim generate marschner-lobb (f_M = 6, alpha = 0.25)".to_string(),
            )
        }
        Kind::Resample => {
            let input = a
                .input
                .as_ref()
                .context("`generate resample` needs --input GRID")?;
            let src = crate::data::io::read_volume(input, "")?;
            let v = generate::resample(&src, size, a.filter.into())?;
            let s = ramp_scene(&name, &v, input);
            let c = format!(
                "pvrsim generate resample --filter {:?} of {} ({}x{}x{})",
                a.filter,
                input.display(),
                src.dims[0],
                src.dims[1],
                src.dims[2]
            );
            (v, s, c)
        }
        Kind::PaperEngine
        | Kind::PaperBonsai
        | Kind::PaperChest
        | Kind::PaperTree
        | Kind::MeshField
        | Kind::Permuted => {
            unreachable!("handled above")
        }
    };
    let gen_s = t.elapsed().as_secs_f64();
    let scene_path = write_outputs(&vol, &a, &comment, &scene)?;
    println!(
        "generated {}x{}x{} {} in {gen_s:.2} s; wrote {} and {}",
        vol.dims[0],
        vol.dims[1],
        vol.dims[2],
        vol.voxels.voxel_type().name(),
        a.output.display(),
        scene_path.display()
    );
    Ok(())
}

/// Writes the volume to `--output` (attached NRRD, `comment` in its header)
/// and the scene text beside it (same stem, `.toml`); returns the scene's path.
pub(super) fn write_outputs(
    vol: &Volume,
    a: &GenerateArgs,
    comment: &str,
    scene: &str,
) -> anyhow::Result<PathBuf> {
    write_nrrd(vol, &a.output, a.gzip, comment)
        .with_context(|| format!("cannot write {}", a.output.display()))?;
    let scene_path = a.output.with_extension("toml");
    std::fs::write(&scene_path, scene)
        .with_context(|| format!("cannot write {}", scene_path.display()))?;
    Ok(scene_path)
}

/// The file name of `p`, as a scene names its data file.
pub fn file_name(p: &Path) -> anyhow::Result<String> {
    p.file_name()
        .and_then(|n| n.to_str())
        .map(str::to_string)
        .with_context(|| format!("--output {}: not a file name", p.display()))
}

/// A generic scene for a resampled grid: a grey-to-white ramp whose opacity
/// grows with the value, clear below 10 % of the range.
pub(super) fn ramp_scene(name: &str, v: &Volume, input: &Path) -> String {
    let rows = [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [0.1, 0.3, 0.3, 0.4, 0.0],
        [0.5, 0.8, 0.6, 0.4, 0.05],
        [1.0, 1.0, 1.0, 1.0, 0.3],
    ];
    let unit = v.spacing.iter().cloned().fold(f64::INFINITY, f64::min);
    volume_scene_toml(
        name,
        v,
        &VolumeSceneSpec {
            about: vec![format!("pvrsim generate resample of {}", input.display())],
            view_dir: [-1.0, 0.55, 0.45],
            up: [0.0, 0.0, 1.0],
            size: (256, 256),
            tf_rows: &rows,
            unit_distance: unit,
            tf_about: vec![
                "Transfer function: clear below 10 % of the range, then a warm grey ramp to white whose".into(),
                "opacity rises to 0.3 per unit distance (= the smallest spacing) at the maximum.".into(),
            ],
        },
    )
}

/// `generate paper-*`: `--input` resampled to the paper's size as u8 (the
/// source's value range onto 0..255), with a scene using the paper's
/// transfer function: grey, opacity equal to the normalised voxel value
/// (per unit distance = the smallest new spacing).
/// `run` has checked that `--output` names a `.nrrd` file.
fn paper(a: &GenerateArgs, size: [u64; 3]) -> anyhow::Result<()> {
    if a.size != "64" {
        bail!("--size: `generate paper-*` has the paper's size ({size:?}); drop --size");
    }
    let input = a.input.as_ref().with_context(|| {
        "`generate paper-*` needs --input GRID (a shared grid, e.g. \
         ../shared/data/colin27-brain.nii.gz or mni152_t1.nii.gz)"
    })?;
    let t = std::time::Instant::now();
    let src = crate::data::io::read_volume(input, "")?;
    let v = generate::resample_u8(&src, size, a.filter.into())?;
    let name = file_name(&a.output)?;
    let rows = [[0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0, 1.0]];
    let unit = v.spacing.iter().cloned().fold(f64::INFINITY, f64::min);
    let what = format!("{:?}", a.kind);
    let scene = volume_scene_toml(
        &name,
        &v,
        &VolumeSceneSpec {
            about: vec![
                format!(
                    "pvrsim generate {what}: a stand-in of the paper's size {}x{}x{}, NOT the paper's data:",
                    size[0], size[1], size[2]
                ),
                format!(
                    "{} ({}x{}x{}) resampled ({:?}), its value range mapped onto u8 0..255.",
                    input.display(),
                    src.dims[0],
                    src.dims[1],
                    src.dims[2],
                    a.filter
                ),
            ],
            view_dir: [-1.0, 0.55, 0.45],
            up: [0.0, 0.0, 1.0],
            size: (256, 256),
            tf_rows: &rows,
            unit_distance: unit,
            tf_about: vec![
                "The paper's transfer function: grey, opacity equal to the normalised voxel value".into(),
                "(per unit distance = the smallest spacing).".into(),
            ],
        },
    );
    let gen_s = t.elapsed().as_secs_f64();
    let comment = format!("pvrsim generate {what} from {}", input.display());
    let scene_path = write_outputs(&v, a, &comment, &scene)?;
    println!(
        "generated {}x{}x{} u8 in {gen_s:.2} s; wrote {} and {}",
        v.dims[0],
        v.dims[1],
        v.dims[2],
        a.output.display(),
        scene_path.display()
    );
    Ok(())
}
