//! Built-in data for `pvrsim calibrate` and `pvrsim fidelity`: the small aorta
//! mesh (`tests/data/aorta-small.vtk`, 20,169 tetrahedra) and its two
//! scenes, compiled into the binary so that calibration works from any
//! directory and from an installed binary. They are written to a private
//! temporary folder for the run (the scene loader reads files) and removed
//! afterwards.

use std::path::{Path, PathBuf};

use anyhow::Context;

/// The mesh, byte for byte.
pub const AORTA_SMALL_VTK: &[u8] = include_bytes!("../../tests/data/aorta-small.vtk");
/// Its side view (300 x 100 style framing, 100 x 100 pixels here).
pub const VIEW_A: &str = include_str!("../../tests/data/aorta-small-view-a.toml");
/// Its end view.
pub const VIEW_B: &str = include_str!("../../tests/data/aorta-small-view-b.toml");

/// The built-in scenes on disk for the length of a run; removed on drop.
#[derive(Debug)]
pub struct BuiltIn {
    dir: PathBuf,
    /// The two scene files (view A, view B).
    pub scenes: Vec<PathBuf>,
}

impl BuiltIn {
    /// Writes the mesh and both scenes into a new folder under the system's
    /// temporary directory.
    pub fn write() -> anyhow::Result<BuiltIn> {
        let base = std::env::temp_dir();
        let dir = base.join(format!(
            "pvrsim-calibrate-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0)
        ));
        std::fs::create_dir_all(&dir).with_context(|| {
            format!(
                "cannot create a folder for the built-in calibration data under {}",
                base.display()
            )
        })?;
        let put = |name: &str, bytes: &[u8]| -> anyhow::Result<PathBuf> {
            let p = dir.join(name);
            std::fs::write(&p, bytes).with_context(|| format!("writing {}", p.display()))?;
            Ok(p)
        };
        put("aorta-small.vtk", AORTA_SMALL_VTK)?;
        let a = put("aorta-small-view-a.toml", VIEW_A.as_bytes())?;
        let b = put("aorta-small-view-b.toml", VIEW_B.as_bytes())?;
        Ok(BuiltIn {
            dir,
            scenes: vec![a, b],
        })
    }

    /// Writes the hydrogen atom grid (`n`³ u8 samples, as `pvrsim generate
    /// hydrogen --size n` makes it) and its scene into the folder; returns
    /// the scene's path.
    pub fn write_grid(&self, n: u64) -> anyhow::Result<PathBuf> {
        let name = format!("hydrogen-{n}.nrrd");
        let v = crate::data::volume::generate::hydrogen(n);
        crate::data::io::volume::write_nrrd(
            &v,
            &self.dir.join(&name),
            false,
            "pvrsim calibrate: built-in hydrogen",
        )?;
        let scene = crate::data::volume::scene::hydrogen_scene(&name, &v);
        let p = self.dir.join(format!("hydrogen-{n}.toml"));
        std::fs::write(&p, scene).with_context(|| format!("writing {}", p.display()))?;
        Ok(p)
    }

    /// The folder holding the files.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

impl Drop for BuiltIn {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_data_reads_back_from_its_folder() {
        let b = BuiltIn::write().unwrap();
        let dir = b.dir().to_path_buf();
        let mesh = crate::data::io::read_mesh(&dir.join("aorta-small.vtk")).unwrap();
        assert_eq!(mesh.tets.len(), 20_169);
        for s in &b.scenes {
            let text = std::fs::read_to_string(s).unwrap();
            assert!(text.contains("path  = \"aorta-small.vtk\""), "{text}");
        }
        let grid = b.write_grid(16).unwrap();
        let v = crate::data::io::read_volume(&grid.with_extension("nrrd"), "").unwrap();
        assert_eq!(v.dims, [16, 16, 16]);
        drop(b);
        assert!(!dir.exists());
    }
}
