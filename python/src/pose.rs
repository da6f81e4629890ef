//! The pose a solver returns: `R`, `t`, and `s` where the problem has a scale.

use nalgebra::{Matrix3, Vector3};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;

/// A relative or absolute pose: `R` (3x3 rotation), `t` (3,), `s` (the scale, or `None`), `q`
/// (the unit quaternion `[w, x, y, z]` of `R`), `certified` (the error bound an interval
/// Krawczyk test proved for the solved unknowns, or `None`). Which frame maps to which is the
/// function's docstring's convention.
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
    /// A proof that an exact root of the solved system lies within this distance (largest
    /// over the unknowns) of the returned one, or `None`: not certified, or not a solve (an
    /// estimate's pose reports it in `info["certified"]`).
    pub certified: Option<f64>,
}

impl Pose {
    /// The pose of a rotation, translation and optional scale.
    pub fn new(py: Python<'_>, r: &Matrix3<f64>, t: &Vector3<f64>, s: Option<f64>) -> PyResult<Self> {
        let q = nalgebra::UnitQuaternion::from_matrix(r);
        let q = if q.w < 0.0 { [-q.w, -q.i, -q.j, -q.k] } else { [q.w, q.i, q.j, q.k] };
        let rows: Vec<Vec<f64>> = (0..3).map(|i| (0..3).map(|j| r[(i, j)]).collect()).collect();
        let r = PyArray2::from_vec2(py, &rows)?.unbind();
        Ok(Self { r, t: PyArray1::from_slice(py, t.as_slice()).unbind(), s, q: PyArray1::from_slice(py, &q).unbind(), certified: None })
    }

    /// The same pose with the error bound of its certificate (`None`: not certified).
    pub fn certified(self, bound: Option<f64>) -> Self {
        Self { certified: bound, ..self }
    }
}

#[pymethods]
impl Pose {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let r = self.r.bind(py).repr()?;
        let t = self.t.bind(py).repr()?;
        let certified = match self.certified {
            Some(b) => format!(", certified={b:.1e}"),
            None => String::new(),
        };
        Ok(match self.s {
            Some(s) => format!("Pose(R={r}, t={t}, s={s}{certified})"),
            None => format!("Pose(R={r}, t={t}{certified})"),
        })
    }
}
