//! Tetrahedral meshes in memory: read with the crate's readers, built from
//! numpy arrays and checked by the crate's own validation
//! ([`TetMesh::validate`]: indices in range, coordinates and values
//! finite), written with its legacy VTK writer when a job needs a file.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use numpy::{PyArray1, PyArray2, PyReadonlyArray2};
use pvrsim::data::locality::Renumbering;
use pvrsim::data::{Field, TetMesh};
use pyo3::prelude::*;

use crate::arrays::{from_numpy, to_numpy};

/// The name the validation's messages give to arrays from Python.
pub const ARRAYS: &str = "<arrays>";

/// A mesh held by the Rust side (see `pvrsim.Mesh`).
#[pyclass(module = "pvrsim._native", frozen)]
pub struct NativeMesh {
    /// The mesh.
    pub mesh: Arc<TetMesh>,
    /// How the load path renumbered a file's mesh (for each index, the
    /// file's), `None` when it keeps the file's numbering.
    pub renumbering: Option<Arc<Renumbering>>,
}

#[pymethods]
impl NativeMesh {
    /// Reads a mesh file (.vtk, .vtu, .pvtu, .inp), as the command line does.
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let r = crate::interrupt::run(py, None, move || pvrsim::data::io::load_mesh(&path))?;
        match r {
            Ok(l) => Ok(NativeMesh {
                mesh: Arc::new(l.mesh),
                renumbering: l.renumbering.map(Arc::new),
            }),
            Err(e) => Err(crate::errors::library_error(py, e.into())),
        }
    }

    /// Builds a mesh from C-contiguous arrays: points (N, 3) float64, tets
    /// (M, 4) int64, fields as (name, (N, k) float64) pairs; validated.
    #[staticmethod]
    fn from_arrays(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        tets: PyReadonlyArray2<'_, i64>,
        fields: Vec<(String, PyReadonlyArray2<'_, f64>)>,
    ) -> PyResult<Self> {
        crate::errors::guard(py, || build(py, points, tets, fields))
    }

    /// The points, (N, 3) float64.
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let flat: Vec<f64> = self.mesh.points.iter().flatten().copied().collect();
        to_numpy(py, [self.mesh.points.len(), 3], flat)
    }

    /// The tetrahedra, (M, 4) int64.
    fn tets<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let flat: Vec<i64> = self.mesh.tets.iter().flatten().map(|&v| v as i64).collect();
        to_numpy(py, [self.mesh.tets.len(), 4], flat)
    }

    /// The point-data fields: (name, (N, components) float64) pairs.
    fn fields<'py>(&self, py: Python<'py>) -> Vec<(String, Bound<'py, PyArray2<f64>>)> {
        self.mesh
            .fields
            .iter()
            .map(|f| {
                let n = f.values.len() / f.components.max(1);
                let a = to_numpy(py, [n, f.components], f.values.clone());
                (f.name.clone(), a)
            })
            .collect()
    }

    /// Writes the mesh as binary legacy VTK (the crate's writer).
    fn write_vtk(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let m = self.mesh.clone();
        crate::interrupt::run(py, None, move || {
            pvrsim::data::io::write_vtk_legacy(&m, &path, true)
        })?
        .map_err(|e| crate::errors::library_error(py, e.into()))
    }

    /// For each vertex, its index in the file, or `None` when the mesh
    /// keeps the file's numbering (int64).
    fn file_vertex_ids<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<i64>>> {
        let r = self.renumbering.as_ref()?;
        Some(PyArray1::from_vec(
            py,
            r.vertices.iter().map(|&v| i64::from(v)).collect(),
        ))
    }

    /// For each tetrahedron, its index in the file, or `None` when the mesh
    /// keeps the file's numbering (int64).
    fn file_cell_ids<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<i64>>> {
        let r = self.renumbering.as_ref()?;
        Some(PyArray1::from_vec(
            py,
            r.cells.iter().map(|&v| i64::from(v)).collect(),
        ))
    }

    /// Points and tetrahedra, for `repr`.
    fn counts(&self) -> (usize, usize) {
        (self.mesh.points.len(), self.mesh.tets.len())
    }
}

/// [`NativeMesh::from_arrays`]: the mesh, validated.
fn build(
    py: Python<'_>,
    points: PyReadonlyArray2<'_, f64>,
    tets: PyReadonlyArray2<'_, i64>,
    fields: Vec<(String, PyReadonlyArray2<'_, f64>)>,
) -> PyResult<NativeMesh> {
    let pts: Vec<[f64; 3]> = points
        .as_array()
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect();
    let mut cells = Vec::with_capacity(tets.as_array().nrows());
    for (t, r) in tets.as_array().rows().into_iter().enumerate() {
        let mut c = [0u32; 4];
        for (k, &v) in r.iter().enumerate() {
            c[k] = u32::try_from(v).map_err(|_| {
                crate::errors::data_error(
                    py,
                    format!(
                        "{ARRAYS}: cell {t}: vertex index {v} is out of range (the mesh has {} points)",
                        pts.len()
                    ),
                )
            })?;
        }
        cells.push(c);
    }
    let fields = fields
        .into_iter()
        .map(|(name, a)| {
            let (values, (_, components)) = from_numpy(&a);
            Field {
                name,
                components,
                values,
            }
        })
        .collect();
    let mesh = TetMesh {
        points: pts,
        tets: cells,
        fields,
    };
    mesh.validate(Path::new(ARRAYS))
        .map_err(|e| crate::errors::data_error(py, e.to_string()))?;
    Ok(NativeMesh {
        mesh: Arc::new(mesh),
        renumbering: None,
    })
}
