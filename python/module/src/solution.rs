//! What a solve returns to Python: the solution's fields by name, read as `x["t"]` or `x.t`,
//! and `certified`.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyAttributeError, PyKeyError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::problem::Field;

/// A validated solution: each field of the problem's solution by name (`x["t"]` or `x.t`; a
/// float for a scalar, an array of the field's shape otherwise), and `certified`: the bound on
/// the distance to an exact root that an interval Krawczyk test proved, or `None` where the
/// proof did not go through or was not asked. `keys()`, `items()`, `in` and `dict(x)` work as
/// on a dict.
#[pyclass(module = "simhc_pymodule", frozen)]
pub struct Solution {
    values: Py<PyDict>,
}

impl Solution {
    /// The solution of the numbers `x`, laid out as `fields`, with its certificate's bound.
    pub fn new(py: Python<'_>, fields: &[Field], x: &[f64], certified: Option<f64>) -> PyResult<Self> {
        Ok(Self { values: values(py, fields, x, certified)?.unbind() })
    }
}

/// The fields of `x` (laid out as `fields`) in a dict, with `certified`.
fn values<'py>(py: Python<'py>, fields: &[Field], x: &[f64], certified: Option<f64>) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    let mut offset = 0;
    for f in fields {
        let v = &x[offset..offset + f.len()];
        offset += f.len();
        if f.shape.is_empty() {
            dict.set_item(f.name, v[0])?;
        } else {
            dict.set_item(f.name, PyArray1::from_slice(py, v).reshape(f.shape.clone())?)?;
        }
    }
    dict.set_item("certified", certified)?;
    Ok(dict)
}

#[pymethods]
impl Solution {
    fn __getitem__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        self.values.bind(py).get_item(name)?.ok_or_else(|| PyKeyError::new_err(name.to_string()))
    }

    fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        self.values.bind(py).get_item(name)?.ok_or_else(|| {
            let names: Vec<String> = self.values.bind(py).keys().iter().map(|k| k.to_string()).collect();
            PyAttributeError::new_err(format!("the solution has no field `{name}`; it has {}", names.join(", ")))
        })
    }

    fn __contains__(&self, py: Python<'_>, name: &str) -> PyResult<bool> {
        self.values.bind(py).contains(name)
    }

    fn __len__(&self, py: Python<'_>) -> usize {
        self.values.bind(py).len()
    }

    fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.values.bind(py).keys().into_any().try_iter().map(Bound::into_any)
    }

    /// The field names, then `certified`.
    fn keys<'py>(&self, py: Python<'py>) -> Bound<'py, PyList> {
        self.values.bind(py).keys()
    }

    /// `(name, value)` pairs.
    fn items<'py>(&self, py: Python<'py>) -> Bound<'py, PyList> {
        self.values.bind(py).items()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let parts: PyResult<Vec<String>> = self.values.bind(py).iter().map(|(k, v)| Ok(format!("{}={}", k.str()?, v.repr()?))).collect();
        Ok(format!("Solution({})", parts?.join(", ")))
    }
}
