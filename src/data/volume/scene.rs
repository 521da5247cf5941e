//! Scene files for generated volumes: an orthographic camera that frames
//! the volume's bounding sphere from any direction, a transfer function
//! given over the normalised value range, and a comment block that says how
//! both were chosen and how opaque the central ray is.

use crate::data::Volume;
use crate::scene::transfer::TransferFunction;

/// What a generated scene shows and how.
#[derive(Debug, Clone)]
pub struct VolumeSceneSpec<'a> {
    /// Comment lines describing the data (without `#`).
    pub about: Vec<String>,
    /// Direction from the target to the eye (need not be unit length).
    pub view_dir: [f64; 3],
    /// Camera up vector.
    pub up: [f64; 3],
    /// Image size.
    pub size: (u32, u32),
    /// `[s_norm, r, g, b, opacity]` rows.
    pub tf_rows: &'a [[f64; 5]],
    /// Opacity unit distance (world units).
    pub unit_distance: f64,
    /// Why the transfer function looks as it does (comment lines).
    pub tf_about: Vec<String>,
}

/// Accumulated alpha along the segment `a -> b` through the trilinear
/// field, by midpoint sums of the extinction over `steps` pieces
/// (`alpha = 1 - exp(-sum tau(s) dt)`); outside the grid tau = 0.
pub fn ray_alpha(
    v: &Volume,
    tf: &TransferFunction,
    range: [f64; 2],
    a: [f64; 3],
    b: [f64; 3],
    steps: usize,
) -> f64 {
    let len = (0..3).map(|i| (b[i] - a[i]).powi(2)).sum::<f64>().sqrt();
    let dt = len / steps as f64;
    let depth: f64 = (0..steps)
        .map(|k| {
            let t = (k as f64 + 0.5) / steps as f64;
            let p = std::array::from_fn(|i| a[i] + t * (b[i] - a[i]));
            v.trilinear(p).map_or(0.0, |s| {
                tf.extinction((s - range[0]) / (range[1] - range[0]))
            }) * dt
        })
        .sum();
    1.0 - (-depth).exp()
}

/// The scene TOML for `v` stored as `data_file_name` beside the scene.
pub fn volume_scene_toml(data_file_name: &str, v: &Volume, spec: &VolumeSceneSpec) -> String {
    let (lo, hi) = v.bounds();
    let centre: [f64; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
    let diag = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    let dn = {
        let d = spec.view_dir;
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        d.map(|x| x / l)
    };
    let r4 = |x: f64| (x * 1e4).round() / 1e4;
    let eye: [f64; 3] = std::array::from_fn(|a| r4(centre[a] + dn[a] * 2.0 * diag));
    let height = r4(diag * 1.05);
    let [vlo, vhi] = v.value_range();
    let range = if vlo < vhi {
        [vlo, vhi]
    } else {
        [vlo, vlo + 1.0]
    };
    let tf = TransferFunction::from_rows(spec.tf_rows, spec.unit_distance);
    // The central ray, from the eye side of the box to the far side.
    let far: [f64; 3] = std::array::from_fn(|a| centre[a] - dn[a] * diag);
    let near: [f64; 3] = std::array::from_fn(|a| centre[a] + dn[a] * diag);
    let alpha = ray_alpha(v, &tf, range, near, far, 4000);

    let mut s = String::new();
    for l in &spec.about {
        s += &format!("# {l}\n");
    }
    s += &format!(
        "# Grid: {}x{}x{} {} samples, spacing [{}, {}, {}], world box [{}, {}, {}]..[{}, {}, {}].\n",
        v.dims[0], v.dims[1], v.dims[2], v.voxels.voxel_type().name(),
        v.spacing[0], v.spacing[1], v.spacing[2], lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
    );
    s += "# Camera: orthographic, eye at twice the box diagonal from the centre along the view\n";
    s += "# direction; height = 1.05 x the box diagonal, so the whole box fits from any direction.\n";
    s += &format!("# range = the value range [{}, {}].\n", range[0], range[1]);
    for l in &spec.tf_about {
        s += &format!("# {l}\n");
    }
    s += &format!(
        "# Accumulated alpha along the central ray (trilinear field, 4000 midpoint steps): {alpha:.3}.\n"
    );
    s += "\n[data]\n";
    s += &format!("path  = {data_file_name:?}\nfield = {:?}\n", v.field);
    s += &format!("range = [{}, {}]\n", range[0], range[1]);
    let vec = |p: [f64; 3]| format!("[{}, {}, {}]", p[0], p[1], p[2]);
    s += "\n[camera]\n";
    s += &format!(
        "eye        = {}\ntarget     = {}\nup         = {}\n",
        vec(eye),
        vec(centre.map(r4)),
        vec(spec.up)
    );
    s += &format!("projection = \"orthographic\"\nheight     = {height}\n");
    s += &format!(
        "\n[image]\nwidth      = {}\nheight     = {}\nbackground = [0, 0, 0]\n",
        spec.size.0, spec.size.1
    );
    s += &format!(
        "\n[transfer]\nunit_distance = {}\npoints = [\n",
        spec.unit_distance
    );
    for r in spec.tf_rows {
        s += &format!("  [{}, {}, {}, {}, {}],\n", r[0], r[1], r[2], r[3], r[4]);
    }
    s += "]\n";
    s
}

/// The scene of [`hydrogen`](super::generate::hydrogen)`(n)` stored as
/// `data_file_name`.
pub fn hydrogen_scene(data_file_name: &str, v: &Volume) -> String {
    // Faint blue for the low tail, green-yellow for the lobes' flanks, red
    // and the most opaque for the clamped cores (value 255).
    let rows = [
        [0.0, 0.0, 0.0, 1.0, 0.0],
        [0.04, 0.0, 0.2, 1.0, 0.0],
        [0.1, 0.0, 0.5, 1.0, 0.02],
        [0.4, 0.2, 1.0, 0.2, 0.06],
        [0.8, 1.0, 1.0, 0.0, 0.15],
        [1.0, 1.0, 0.1, 0.0, 0.5],
    ];
    volume_scene_toml(
        data_file_name,
        v,
        &VolumeSceneSpec {
            about: vec![
                "pvrsim generate hydrogen: the analytic hydrogen atom of KVS's HydrogenVolumeData (the splatting".into(),
                "paper's test volume): value = trunc(min((6 r^2 e^(-r/2) (3 cos^2(theta) - 1))^2, 255)), u8,".into(),
                "over the 32-unit cube centred on the origin (see src/data/volume/generate.rs).".into(),
            ],
            view_dir: [1.0, -2.0, 1.0],
            up: [0.0, 0.0, 1.0],
            size: (256, 256),
            tf_rows: &rows,
            unit_distance: 1.0,
            tf_about: vec![
                "Transfer function: values below 4 % of the range (the exponential tail) are clear; blue->green->".into(),
                "yellow->red with opacity rising to 0.5 per unit length at the clamped cores of the two z lobes".into(),
                "and the xy ring.".into(),
            ],
        },
    )
}

/// The scene of [`marschner_lobb`](super::generate::marschner_lobb)`(n)`.
pub fn marschner_lobb_scene(data_file_name: &str, v: &Volume) -> String {
    // The classic view shows the iso-surface near rho = 0.5: a narrow
    // opacity peak there makes the ripples visible.
    let rows = [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [0.4, 0.0, 0.3, 1.0, 0.0],
        [0.5, 1.0, 1.0, 1.0, 0.6],
        [0.6, 1.0, 0.3, 0.0, 0.0],
        [1.0, 1.0, 0.0, 0.0, 0.0],
    ];
    volume_scene_toml(
        data_file_name,
        v,
        &VolumeSceneSpec {
            about: vec![
                "pvrsim generate marschner-lobb: the Marschner-Lobb test signal (f_M = 6, alpha = 0.25) on [-1, 1]^3, f32".into(),
                "(see src/data/volume/generate.rs).".into(),
            ],
            view_dir: [0.6, -1.0, 0.8],
            up: [0.0, 0.0, 1.0],
            size: (256, 256),
            tf_rows: &rows,
            unit_distance: 0.05,
            tf_about: vec![
                "Transfer function: a narrow opacity tent (0.6 per 0.05 units) around rho = 0.5, the level whose".into(),
                "iso-surface shows the ripples that reveal reconstruction error; clear elsewhere.".into(),
            ],
        },
    )
}
