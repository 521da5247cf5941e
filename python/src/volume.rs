//! Regular grids in memory: read with the crate's readers, built from a
//! numpy array `a[z, y, x]` and checked by [`Volume::new`] (sample count,
//! spacing finite and positive, origin and float samples finite), written
//! as NRRD with the crate's writer when a job needs a file.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use numpy::{Element, PyReadonlyArray3};
use pvrsim::data::{Volume, Voxels};
use pyo3::prelude::*;

/// A grid held by the Rust side (see `pvrsim.Volume`).
#[pyclass(module = "pvrsim._native", frozen)]
pub struct NativeVolume {
    /// The grid.
    pub volume: Arc<Volume>,
}

/// The samples of `a[z, y, x]` and the dims along x, y, z.
fn samples<T: Element + Copy>(a: &Bound<'_, PyAny>) -> PyResult<(Vec<T>, [u64; 3])> {
    let a: PyReadonlyArray3<'_, T> = a.extract()?;
    let (v, (nz, ny, nx)) = crate::arrays::from_numpy(&a);
    Ok((v, [nx as u64, ny as u64, nz as u64]))
}

/// The samples `v` (dims along x, y, z) as `a[z, y, x]`.
fn to_array<'py, T: Element + Copy>(py: Python<'py>, v: &[T], dims: [u64; 3]) -> Bound<'py, PyAny> {
    let shape = [dims[2] as usize, dims[1] as usize, dims[0] as usize];
    crate::arrays::to_numpy(py, shape, v.to_vec()).into_any()
}

#[pymethods]
impl NativeVolume {
    /// Reads a grid file (.nhdr, .nrrd, .nii, .nii.gz, .vti, .fld); `field`
    /// picks the array of a file that holds several ("" for the only one).
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf, field: String) -> PyResult<Self> {
        let r = crate::interrupt::run(py, None, move || {
            pvrsim::data::io::read_volume(&path, &field)
        })?;
        match r {
            Ok(v) => Ok(NativeVolume {
                volume: Arc::new(v),
            }),
            Err(e) => Err(crate::errors::library_error(py, e.into())),
        }
    }

    /// Builds a grid from a C-contiguous array `a[z, y, x]` of uint8,
    /// uint16, int16 or float32 (`kind` names which).
    #[staticmethod]
    fn from_array(
        py: Python<'_>,
        a: &Bound<'_, PyAny>,
        kind: &str,
        spacing: [f64; 3],
        origin: [f64; 3],
        field: String,
    ) -> PyResult<Self> {
        crate::errors::guard(py, || build(py, a, kind, spacing, origin, field))
    }

    /// The samples as `a[z, y, x]` in their own dtype.
    fn array<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let d = self.volume.dims;
        match &self.volume.voxels {
            Voxels::U8(v) => to_array(py, v, d),
            Voxels::U16(v) => to_array(py, v, d),
            Voxels::I16(v) => to_array(py, v, d),
            Voxels::F32(v) => to_array(py, v, d),
        }
    }

    /// Samples along x, y, z.
    fn dims(&self) -> [u64; 3] {
        self.volume.dims
    }

    /// Spacing along x, y, z.
    fn spacing(&self) -> [f64; 3] {
        self.volume.spacing
    }

    /// World position of sample (0, 0, 0).
    fn origin(&self) -> [f64; 3] {
        self.volume.origin
    }

    /// The scalar's name.
    fn field(&self) -> String {
        self.volume.field.clone()
    }

    /// Writes the grid as an attached raw NRRD (the crate's writer).
    fn write_nrrd(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let v = self.volume.clone();
        py.allow_threads(move || {
            pvrsim::data::io::volume::write_nrrd(
                &v,
                &path,
                false,
                "written by the pvrsim Python module",
            )
        })
        .map_err(|e| crate::errors::library_error(py, e.into()))
    }
}

/// [`NativeVolume::from_array`]: the grid, validated.
fn build(
    py: Python<'_>,
    a: &Bound<'_, PyAny>,
    kind: &str,
    spacing: [f64; 3],
    origin: [f64; 3],
    field: String,
) -> PyResult<NativeVolume> {
    let (voxels, dims) = match kind {
        "uint8" => samples::<u8>(a).map(|(v, d)| (Voxels::U8(v), d))?,
        "uint16" => samples::<u16>(a).map(|(v, d)| (Voxels::U16(v), d))?,
        "int16" => samples::<i16>(a).map(|(v, d)| (Voxels::I16(v), d))?,
        "float32" => samples::<f32>(a).map(|(v, d)| (Voxels::F32(v), d))?,
        other => {
            return Err(crate::errors::data_error(
                py,
                format!("array: dtype {other} is not a voxel type"),
            ))
        }
    };
    let v = Volume::new(
        Path::new(crate::mesh::ARRAYS),
        dims,
        spacing,
        origin,
        field,
        voxels,
    )
    .map_err(|e| crate::errors::data_error(py, e.to_string()))?;
    Ok(NativeVolume {
        volume: Arc::new(v),
    })
}
