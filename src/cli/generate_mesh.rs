//! `pvrsim generate mesh-field`: a tetrahedral mesh's field sampled on a
//! regular grid (see `data::volume::from_mesh`), with a scene that renders
//! the grid as the mesh's scene renders the mesh: same camera, image,
//! transfer function and, written explicitly, the same value range. Then
//! `pvrsim render` of both scenes compares the cell renderer and the grid
//! renderers on one physical field. `pvrsim generate permuted`: a copy of a
//! mesh in a random order, for the load path's renumbering.

use anyhow::{bail, Context};

use super::generate::GenerateArgs;
use crate::data::dataset::is_mesh_file;
use crate::data::io::read_mesh;
use crate::data::volume::from_mesh::{dims_along_longest, sample_mesh_field};
use crate::scene::Scene;

/// Runs `generate mesh-field` (`a.kind` is `MeshField`).
pub fn run(a: GenerateArgs) -> anyhow::Result<()> {
    super::generate::check_output(&a)?;
    let name = &super::generate::file_name(&a.output)?;
    let a = &a;
    let input = a.input.as_ref().context(
        "`generate mesh-field` needs --input SCENE.toml (a mesh scene) or --input MESH \
         (.vtk, .vtu, .pvtu, .inp) with --field",
    )?;
    let is_scene = input
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let scene = if is_scene {
        let s = Scene::load(input)?;
        if !is_mesh_file(&s.data.path) {
            bail!(
                "--input {}: its data ({}) is not a tetrahedral mesh ({})",
                input.display(),
                s.data.path.display(),
                crate::data::io::SUPPORTED
            );
        }
        if let Some(f) = &a.field {
            if *f != s.data.field {
                bail!(
                    "--field {f:?}: the scene {} renders field {:?}; drop --field or edit the scene",
                    input.display(),
                    s.data.field
                );
            }
        }
        Some(s)
    } else if is_mesh_file(input) {
        None
    } else {
        bail!(
            "--input {}: expected a mesh scene (.toml) or a mesh ({})",
            input.display(),
            crate::data::io::SUPPORTED
        );
    };
    let mesh_path = scene
        .as_ref()
        .map_or(input.clone(), |s| s.data.path.clone());
    let mesh_path = mesh_path.as_path();
    let t = std::time::Instant::now();
    let mesh = read_mesh(mesh_path)?;
    let field = match (&scene, &a.field) {
        (Some(s), _) => s.data.field.clone(),
        (None, Some(f)) => f.clone(),
        (None, None) => match mesh.fields.as_slice() {
            [only] => only.name.clone(),
            fields => bail!(
                "--field: {} has {} point-data fields ({}); name one",
                mesh_path.display(),
                fields.len(),
                fields
                    .iter()
                    .map(|f| f.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
    };
    let values = mesh
        .scalar(&field)
        .with_context(|| format!("{}", mesh_path.display()))?;
    let lo = values.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let range = scene
        .as_ref()
        .and_then(|s| s.data.range)
        .unwrap_or([lo, hi]);
    let dims = grid_dims(&a.size, &mesh.bounds())?;
    crate::budget::volume("--size", dims, 4)?;
    let vol = sample_mesh_field(&mesh, &field, &values, dims, range[0], mesh_path)?;
    let gen_s = t.elapsed().as_secs_f64();
    let comment = format!(
        "pvrsim generate mesh-field: {} field {field:?} sampled on {}x{}x{} over its bounding box \
         (barycentric in each tet; {} outside the mesh)",
        mesh_path.display(),
        dims[0],
        dims[1],
        dims[2],
        range[0]
    );
    let text = match scene {
        Some(mut s) => {
            s.data.range = Some(range);
            let mut t = format!(
                "# {comment}.\n# Camera, image and transfer function copied from {}; the range is \
                 written\n# explicitly so that s_norm means what it means for the mesh.\n\n",
                input.display()
            );
            t += &s.to_toml(name);
            t
        }
        None => {
            let mut t = format!("# {comment}.\n");
            t += &super::generate::ramp_scene(name, &vol, input);
            t
        }
    };
    let scene_path = super::generate::write_outputs(&vol, a, &comment, &text)?;
    println!(
        "sampled {} ({} tets, field {field}) on {}x{}x{} in {gen_s:.2} s; wrote {} and {}",
        mesh_path.display(),
        mesh.tets.len(),
        dims[0],
        dims[1],
        dims[2],
        a.output.display(),
        scene_path.display()
    );
    Ok(())
}

/// Runs `generate permuted` (`a.kind` is `Permuted`): reads --input,
/// renumbers its vertices and cells at random (seed 1) and writes binary
/// legacy VTK.
pub fn permuted(a: GenerateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.field.is_none() && !a.gzip,
        "--field and --gzip are not used by `generate permuted` (it copies every field)"
    );
    anyhow::ensure!(
        crate::data::io::mesh_format(&a.output) == Some(crate::data::io::MeshFormat::VtkLegacy),
        "--output {}: `generate permuted` writes binary legacy VTK; name the file *.vtk",
        a.output.display()
    );
    anyhow::ensure!(
        a.force || !a.output.exists(),
        "-o {}: exists (--force overwrites it)",
        a.output.display()
    );
    let input = a.input.as_ref().with_context(|| {
        format!(
            "`generate permuted` needs --input MESH ({})",
            crate::data::io::SUPPORTED
        )
    })?;
    anyhow::ensure!(
        is_mesh_file(input),
        "--input {}: not a mesh ({})",
        input.display(),
        crate::data::io::SUPPORTED
    );
    let t = std::time::Instant::now();
    let mut mesh = read_mesh(input)?;
    let before = crate::data::locality::locality(&mesh);
    crate::data::locality::permute(&mut mesh, 1);
    let after = crate::data::locality::locality(&mesh);
    crate::data::io::write_vtk_legacy(&mesh, &a.output, true)?;
    println!(
        "permuted {} ({} tets, {} vertices; {:.1} % of sampled cells local before, {:.1} % after) and wrote {} in {:.2} s",
        input.display(),
        mesh.tets.len(),
        mesh.points.len(),
        100.0 * before,
        100.0 * after,
        a.output.display(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `N`: N samples along the bounding box's longest axis and the others in
/// proportion (near-isotropic spacing, at least 2); `NxNxN`: exactly those.
fn grid_dims(size: &str, bounds: &([f64; 3], [f64; 3])) -> anyhow::Result<[u64; 3]> {
    let dims = super::generate::parse_size(size)?;
    if size.contains(['x', 'X']) {
        return Ok(dims);
    }
    dims_along_longest(bounds.0, bounds.1, dims[0])
        .with_context(|| format!("the mesh's bounding box is empty or not finite: {bounds:?}"))
}

#[cfg(test)]
mod tests {
    use super::grid_dims;

    #[test]
    fn one_size_follows_the_longest_axis() {
        let b = ([0.0, 0.0, 0.0], [10.0, 5.0, 2.0]);
        assert_eq!(grid_dims("101", &b).unwrap(), [101, 51, 21]);
        assert_eq!(grid_dims("4x5x6", &b).unwrap(), [4, 5, 6]);
        assert!(grid_dims("1", &b).is_err());
    }
}
