//! numpy arrays to and from the crate's flat vectors, for any element type
//! and any number of axes (row-major, as numpy's C order).

use numpy::ndarray::{Array, Dimension, StrideShape};
use numpy::{Element, IntoPyArray, PyArray, PyReadonlyArray};
use pyo3::prelude::*;

/// A numpy array of `shape` holding `values` (row-major; their count is the
/// shape's product, as every caller builds them).
pub fn to_numpy<'py, T: Element, D: Dimension>(
    py: Python<'py>,
    shape: impl Into<StrideShape<D>>,
    values: Vec<T>,
) -> Bound<'py, PyArray<T, D>> {
    Array::from_shape_vec(shape, values)
        .expect("the values fill the shape")
        .into_pyarray(py)
}

/// The values of `a` in row-major order, with its shape.
pub fn from_numpy<T: Element + Copy, D: Dimension>(
    a: &PyReadonlyArray<'_, T, D>,
) -> (Vec<T>, D::Pattern) {
    let v = a.as_array();
    (v.iter().copied().collect(), v.dim())
}
