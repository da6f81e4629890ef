//! The pose a solver returns: `R`, `t`, and `s` where the problem has a scale.

use crate::arrays::{matrix, vector};
use nalgebra::{Matrix3, Vector3};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;

/// A relative or absolute pose: `R` (3x3 rotation), `t` (3,), `s` (the scale, or `None`), `q`
/// (the unit quaternion `[w, x, y, z]` of `R`). Which frame maps to which is the function's
/// docstring's convention.
#[pyclass(module = "simhc", frozen, get_all)]
#[derive(Debug)]
pub struct Pose {
    /// Rotation, 3x3.
    #[pyo3(name = "R")]
    pub r: Py<PyArray2<f64>>,
    /// Translation, 3.
    pub t: Py<PyArray1<f64>>,
    /// Scale (GRPS), or `None`.
    pub s: Option<f64>,
    /// Unit quaternion `[w, x, y, z]` of `R`.
    pub q: Py<PyArray1<f64>>,
}

impl Pose {
    /// The pose of a rotation, translation and optional scale.
    pub fn new(py: Python<'_>, r: &Matrix3<f64>, t: &Vector3<f64>, s: Option<f64>) -> PyResult<Self> {
        let q = nalgebra::UnitQuaternion::from_matrix(r);
        let q = if q.w < 0.0 { [-q.w, -q.i, -q.j, -q.k] } else { [q.w, q.i, q.j, q.k] };
        Ok(Self { r: matrix(py, r)?.unbind(), t: vector(py, t.as_slice()).unbind(), s, q: vector(py, &q).unbind() })
    }
}

#[pymethods]
impl Pose {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let r = self.r.bind(py).repr()?;
        let t = self.t.bind(py).repr()?;
        Ok(match self.s {
            Some(s) => format!("Pose(R={r}, t={t}, s={s})"),
            None => format!("Pose(R={r}, t={t})"),
        })
    }
}
