//! numpy in and out. Every input goes through `numpy.ascontiguousarray(x, dtype=float64)` (so
//! lists and integer arrays work) and is copied before the GIL is released; a wrong shape or a
//! non-finite value is a [`Failure::Input`] (the module's `InputError`) naming the argument,
//! and the row and column where that helps.

use crate::errors::{Error, Failure};
use nalgebra::Vector3;
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;

/// A float64 copy of `obj` with its shape. A C-contiguous float64 array is read as it is;
/// anything else goes through `numpy.ascontiguousarray` first.
pub fn float_array(obj: &Bound<'_, PyAny>, name: &str) -> Result<(Vec<usize>, Vec<f64>), Error> {
    if let Ok(array) = obj.cast::<PyArrayDyn<f64>>() {
        if array.is_c_contiguous() {
            return copy(array, name);
        }
    }
    static ASCONTIGUOUSARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
    let py = obj.py();
    let convert = ASCONTIGUOUSARRAY.import(py, "numpy", "ascontiguousarray")?;
    let converted = convert.call1((obj, "float64")).map_err(|e| Failure::Input(format!("`{name}`: not an array of numbers ({e})")))?;
    let array = converted.cast::<PyArrayDyn<f64>>().map_err(|e| Failure::Input(format!("`{name}`: {e}")))?;
    copy(array, name)
}

/// The shape and a copy of the numbers of a C-contiguous array.
fn copy(array: &Bound<'_, PyArrayDyn<f64>>, name: &str) -> Result<(Vec<usize>, Vec<f64>), Error> {
    let shape = array.shape().to_vec();
    let data = array.readonly().as_slice().map_err(|e| Failure::Input(format!("`{name}`: {e}")))?.to_vec();
    Ok((shape, data))
}

/// Describes a shape as numpy prints it.
pub fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")),
    }
}

/// An `(N, width)` array, row after row; an error names `name` and the expected shape.
pub fn rows_of(obj: &Bound<'_, PyAny>, name: &str, width: usize) -> Result<(usize, Vec<f64>), Error> {
    let (shape, data) = float_array(obj, name)?;
    match shape.as_slice() {
        [n, w] if *w == width => Ok((*n, data)),
        _ => Err(Failure::Input(format!("`{name}`: expected an array of shape (N, {width}), got shape {}", shape_text(&shape))).into()),
    }
}

/// An `(N, 3)` array as 3-vectors, every value finite; an error names the argument and row.
pub fn vectors(obj: &Bound<'_, PyAny>, name: &str) -> Result<Vec<Vector3<f64>>, Error> {
    let (n, data) = rows_of(obj, name, 3)?;
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        return Err(Failure::Input(format!("correspondence {}, field `{name}`: {} is not finite", i / 3, data[i])).into());
    }
    Ok((0..n).map(|i| Vector3::new(data[3 * i], data[3 * i + 1], data[3 * i + 2])).collect())
}

/// Checks that every array has as many rows as the first.
pub fn same_count(counts: &[(&str, usize)]) -> Result<usize, Failure> {
    let (first, n) = counts[0];
    match counts.iter().find(|(_, m)| *m != n) {
        Some((name, m)) => Err(Failure::Input(format!("`{name}` has {m} rows, `{first}` has {n}: one row per correspondence"))),
        None => Ok(n),
    }
}
