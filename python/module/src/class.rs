//! The one Python class of every problem, [`ProblemSolver`]: numpy in (the rows as one array, or
//! each field by name), checked with errors that say where, the problem's [`DynSolver`] called
//! with the GIL released, a [`Solution`] out.

use crate::arrays::{float_array, shape_text};
use crate::errors::{Error, Exceptions, Failure};
use crate::problem::{fields_len, DynSolver, Field, Fields, MakeSolver};
use crate::solution::Solution;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use simhc::ransac::RansacOptions;
use simhc::solver::EstimateInfo;
use std::sync::{Arc, Mutex};

/// `solve_batch`'s `(x, ok)`.
pub type BatchResult<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<bool>>);

/// A problem's solver, built once when its module is imported; every problem, built-in or
/// declared, is one of these.
///
/// `solve(*arrays, globals=None, *, noise=None, **fields)` (also `solver(...)`) takes the
/// correspondences as one `(N, per_row)` array of rows, fields in the order of `row_fields`, or
/// as one array per field, `(N, *shape)`, in that order or by name; `estimate(..., threshold=..)`
/// takes any number of them, with outliers; `solve_batch` takes `(B, N, per_row)`. A solution
/// comes back by name (`solution_fields`). Errors are the module's `InputError` and
/// `SolveError`. `about` says what the problem solves, its conventions and units.
// `__module__` is set to the registering module when it is imported (`register`).
#[pyclass(module = "simhc_pymodule", frozen)]
pub struct ProblemSolver {
    /// The solver for exact data (noise 0).
    inner: Arc<dyn DynSolver>,
    /// What its data and solution look like.
    fields: Fields,
    /// The solver whose validator allows data with noise `noise` (the problem's unit).
    make: MakeSolver,
    /// Solvers made for other noise levels, by the noise's bits.
    noisy: Mutex<Vec<(u64, Arc<dyn DynSolver>)>>,
    /// The module's exception types.
    exceptions: Arc<Exceptions>,
    /// The module's name, for `repr`.
    module: String,
}

fn described(list: &[Field]) -> Vec<(String, Vec<usize>)> {
    list.iter().map(|f| (f.name.to_string(), f.shape.clone())).collect()
}

impl ProblemSolver {
    /// The Python object of a problem in module `module`: `make(noise)` builds its solver for
    /// data with noise of size `noise` (the validator's tolerance); the one for exact data is
    /// built at once. Its errors are raised as `exceptions`.
    pub fn new(make: MakeSolver, exceptions: Arc<Exceptions>, module: &str) -> Result<Self, String> {
        let inner = make(0.0)?;
        let fields = inner.fields();
        Ok(Self { inner, fields, make, noisy: Mutex::new(Vec::new()), exceptions, module: module.to_string() })
    }

    /// What the problem's data and solution look like.
    pub fn fields(&self) -> &Fields {
        &self.fields
    }

    /// `e` raised as this module's exception.
    fn raise(&self, py: Python<'_>, e: impl Into<Error>) -> PyErr {
        self.exceptions.err(py, e)
    }

    /// The solver for data with noise `noise` (built on first use, then kept).
    fn solver(&self, noise: f64) -> Result<Arc<dyn DynSolver>, Error> {
        if !(noise.is_finite() && noise >= 0.0) {
            return Err(Failure::Input(format!("`noise`: {noise}, expected a number >= 0")).into());
        }
        if noise == 0.0 {
            return Ok(self.inner.clone());
        }
        let mut noisy = self.noisy.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, s)) = noisy.iter().find(|(bits, _)| *bits == noise.to_bits()) {
            return Ok(s.clone());
        }
        let solver = (self.make)(noise).map_err(|e| Error::Python(pyo3::exceptions::PyRuntimeError::new_err(e)))?;
        // A few noise levels are kept; a program that varies it per call rebuilds.
        if noisy.len() >= 8 {
            noisy.clear();
        }
        noisy.push((noise.to_bits(), solver.clone()));
        Ok(solver)
    }

    /// The global numbers: `None` or an array of as many numbers as the global fields hold.
    fn globals(&self, globals: Option<&Bound<'_, PyAny>>) -> Result<Vec<f64>, Error> {
        let expected = fields_len(&self.fields.globals);
        let values = match globals {
            Some(g) => float_array(g, "globals")?.1,
            None => Vec::new(),
        };
        if values.len() != expected {
            return Err(Failure::Input(format!("`globals`: {} numbers, the problem has {expected}", values.len())).into());
        }
        Ok(values)
    }

    /// The correspondences, row-major, and their count: one `(N, per_row)` array of rows, or
    /// one array per field (`(N, *shape)`, or `(N, len)`), positional in `row_fields` order or
    /// by name; an optional field not given is zeros.
    fn data(&self, arrays: &Bound<'_, PyTuple>, named: Option<&Bound<'_, PyDict>>) -> Result<(usize, Vec<f64>), Error> {
        let (n, rows) = self.arrays(arrays, named)?;
        let per_row = fields_len(&self.fields.row);
        if let Some(k) = rows.iter().position(|v| !v.is_finite()) {
            let (i, column, mut end) = (k / per_row, k % per_row, 0);
            let field = self.fields.row.iter().find(|f| {
                end += f.len();
                column < end
            });
            let field = field.map_or("?", |f| f.name);
            return Err(Failure::Input(format!("correspondence {i}, field `{field}`: {} is not finite", rows[k])).into());
        }
        Ok((n, rows))
    }

    /// [`ProblemSolver::data`] before the values are checked.
    fn arrays(&self, arrays: &Bound<'_, PyTuple>, named: Option<&Bound<'_, PyDict>>) -> Result<(usize, Vec<f64>), Error> {
        let row = &self.fields.row;
        let per_row = fields_len(row);
        let named = match named {
            Some(d) => d.iter().map(|(k, v)| Ok((k.extract::<String>()?, v))).collect::<PyResult<Vec<_>>>()?,
            None => Vec::new(),
        };
        if let Some((k, _)) = named.iter().find(|(k, _)| !row.iter().any(|f| f.name == k)) {
            let names: Vec<&str> = row.iter().map(|f| f.name).collect();
            return Err(Failure::Input(format!("`{k}`: not a field of `{}`'s rows ({})", self.inner.name(), names.join(", "))).into());
        }
        if arrays.len() > row.len() {
            return Err(Failure::Input(format!("{} arrays: a row has {} fields", arrays.len(), row.len())).into());
        }
        // One array of whole rows.
        if named.is_empty() && arrays.len() == 1 && row.len() > 1 {
            let (shape, data) = float_array(&arrays.get_item(0)?, "rows")?;
            if let [n, w] = shape.as_slice() {
                if *w == per_row {
                    return Ok((*n, data));
                }
            }
            if shape.get(1) != Some(&row[0].len()) || row[1..].iter().all(|f| !f.optional) {
                return Err(Failure::Input(format!(
                    "`rows`: expected an array of shape (N, {per_row}), got shape {} (or one array per field: {})",
                    shape_text(&shape),
                    row.iter().map(|f| f.name).collect::<Vec<_>>().join(", ")
                ))
                .into());
            }
        }
        // One array per field.
        let mut columns: Vec<Option<(usize, Vec<f64>)>> = vec![None; row.len()];
        for (i, array) in arrays.iter().enumerate() {
            columns[i] = Some(field_values(&array, &row[i])?);
        }
        for (k, array) in &named {
            let i = row.iter().position(|f| f.name == k).expect("checked above");
            if columns[i].is_some() {
                return Err(Failure::Input(format!("`{k}`: given twice, by position and by name")).into());
            }
            columns[i] = Some(field_values(array, &row[i])?);
        }
        let Some((first, n)) = row.iter().zip(&columns).find_map(|(f, c)| c.as_ref().map(|(n, _)| (f.name, *n))) else {
            return Err(Failure::Input(format!("no correspondences: give the rows or the fields {}", names_of(row))).into());
        };
        for (f, c) in row.iter().zip(&columns) {
            match c {
                None if !f.optional => {
                    return Err(Failure::Input(format!("`{}`: missing (the rows' fields are {})", f.name, names_of(row))).into())
                }
                Some((m, _)) if *m != n => {
                    return Err(Failure::Input(format!("`{}` has {m} rows, `{first}` has {n}: one row per correspondence", f.name)).into())
                }
                _ => {}
            }
        }
        let mut rows = Vec::with_capacity(n * per_row);
        for i in 0..n {
            for (f, c) in row.iter().zip(&columns) {
                match c {
                    Some((_, values)) => rows.extend_from_slice(&values[i * f.len()..(i + 1) * f.len()]),
                    None => rows.extend(std::iter::repeat_n(0.0, f.len())),
                }
            }
        }
        Ok((n, rows))
    }

    /// Checks the count of correspondences against what a solve takes.
    fn check_count(&self, n: usize) -> Result<(), Failure> {
        let f = &self.fields;
        match (f.more_rows, n) {
            (false, n) if n != f.rows => Err(Failure::Input(format!(
                "{n} correspondences: `{}` solves exactly {} (use `estimate` for more, with outliers)",
                self.inner.name(),
                f.rows
            ))),
            (true, n) if n < f.rows => {
                Err(Failure::Input(format!("too few correspondences: got {n}, `{}` needs at least {}", self.inner.name(), f.rows)))
            }
            _ => Ok(()),
        }
    }

    fn solve_any(
        &self,
        py: Python<'_>,
        arrays: &Bound<'_, PyTuple>,
        globals: Option<&Bound<'_, PyAny>>,
        noise: Option<f64>,
        named: Option<&Bound<'_, PyDict>>,
    ) -> Result<(Vec<f64>, Option<f64>), Error> {
        let (n, rows) = self.data(arrays, named)?;
        let globals = self.globals(globals)?;
        self.check_count(n)?;
        let solver = self.solver(noise.unwrap_or(0.0))?;
        Ok(py.detach(|| solver.solve(n, &rows, &globals))?)
    }

    #[allow(clippy::too_many_arguments)]
    fn estimate_any(
        &self,
        py: Python<'_>,
        arrays: &Bound<'_, PyTuple>,
        globals: Option<&Bound<'_, PyAny>>,
        threshold: Option<f64>,
        noise: Option<f64>,
        options: impl FnOnce(f64) -> Result<RansacOptions, Failure>,
        named: Option<&Bound<'_, PyDict>>,
    ) -> Result<(Vec<f64>, EstimateInfo), Error> {
        let threshold = threshold
            .or(self.fields.threshold)
            .ok_or_else(|| Failure::Input(format!("`threshold`: required for `{}` (in the unit of its row error)", self.inner.name())))?;
        let options = options(threshold)?;
        let (_, rows) = self.data(arrays, named)?;
        let globals = self.globals(globals)?;
        let solver = self.solver(noise.unwrap_or(self.fields.estimate_noise))?;
        Ok(py.detach(|| solver.estimate(&rows, &globals, &options))?)
    }

    /// `solve_batch` before its errors are raised.
    fn batch<'py>(
        &self,
        py: Python<'py>,
        rows: &Bound<'py, PyAny>,
        globals: Option<&Bound<'py, PyAny>>,
        noise: f64,
    ) -> Result<BatchResult<'py>, Error> {
        let per_row = fields_len(&self.fields.row);
        let (shape, data) = float_array(rows, "rows")?;
        let (b, n) = match shape.as_slice() {
            [b, n, w] if *w == per_row => (*b, *n),
            _ => {
                return Err(Failure::Input(format!(
                    "`rows`: expected an array of shape (B, N, {per_row}), got shape {}",
                    shape_text(&shape)
                ))
                .into());
            }
        };
        self.check_count(n)?;
        let g = fields_len(&self.fields.globals);
        let all_globals: Vec<f64> = match globals {
            None if g == 0 => Vec::new(),
            None => return Err(Failure::Input(format!("`globals`: the problem has {g} global numbers")).into()),
            Some(obj) => {
                let (gs, gd) = float_array(obj, "globals")?;
                match gs.as_slice() {
                    [k] if *k == g => gd.repeat(b),
                    [bb, k] if *bb == b && *k == g => gd,
                    _ => {
                        return Err(
                            Failure::Input(format!("`globals`: expected shape ({g},) or ({b}, {g}), got {}", shape_text(&gs))).into()
                        )
                    }
                }
            }
        };
        let solver = self.solver(noise)?;
        let results = py.detach(|| solver.solve_batch(n, &data, &all_globals));
        let nx = fields_len(&self.fields.solution);
        let mut x = vec![vec![f64::NAN; nx]; b];
        let mut ok = vec![false; b];
        for (i, r) in results.into_iter().enumerate() {
            if let Ok(v) = r {
                x[i].copy_from_slice(&v);
                ok[i] = true;
            }
        }
        let x = if b == 0 { PyArray2::zeros(py, [0, nx], false) } else { PyArray2::from_vec2(py, &x).map_err(PyErr::from)? };
        Ok((x, PyArray1::from_vec(py, ok)))
    }
}

/// The values of one field for every correspondence, from `(N, *shape)` or `(N, len)` (or
/// `(N,)` for a scalar).
fn field_values(array: &Bound<'_, PyAny>, field: &Field) -> Result<(usize, Vec<f64>), Error> {
    let (shape, data) = float_array(array, field.name)?;
    let fits = match shape.split_first() {
        Some((_, rest)) => rest == field.shape.as_slice() || rest == [field.len()],
        None => false,
    };
    if !fits || (field.len() == 1 && shape.len() > 2) {
        let each = shape_text(&[&[0usize][..], &field.shape].concat()).replacen('0', "N", 1);
        return Err(Failure::Input(format!("`{}`: expected an array of shape {each}, got shape {}", field.name, shape_text(&shape))).into());
    }
    Ok((shape[0], data))
}

fn names_of(fields: &[Field]) -> String {
    fields.iter().map(|f| if f.optional { format!("{} (optional)", f.name) } else { f.name.to_string() }).collect::<Vec<_>>().join(", ")
}

/// A robust estimate's info as PoseLib's `info` dict: `iterations`, `num_inliers`,
/// `inlier_ratio`, `inlier_mask` (a bool array), `score`, `refinements`, `models`.
pub fn info_dict<'py>(py: Python<'py>, info: &EstimateInfo) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("iterations", info.iterations)?;
    d.set_item("num_inliers", info.inliers.len())?;
    d.set_item("inlier_ratio", info.inlier_ratio)?;
    d.set_item("inlier_mask", PyArray1::from_slice(py, &info.inlier_mask))?;
    d.set_item("score", info.score)?;
    d.set_item("refinements", info.refinements)?;
    d.set_item("models", info.hypotheses)?;
    // The proved distance of the model to an exact root of its best-fitting inliers' system
    // (None: not certified, or not asked).
    d.set_item("certified", info.certified.and_then(|c| c.ok()))?;
    Ok(d)
}

/// The estimator's options from keyword arguments (PoseLib's defaults).
#[allow(clippy::too_many_arguments)]
pub fn ransac_options(
    threshold: f64,
    max_iterations: usize,
    min_iterations: usize,
    confidence: f64,
    seed: u64,
    local_optimization: bool,
    refine_rounds: usize,
    skip_explained: bool,
) -> Result<RansacOptions, Failure> {
    if !(threshold.is_finite() && threshold > 0.0) {
        return Err(Failure::Input(format!("`threshold`: {threshold}, expected a positive number")));
    }
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(Failure::Input(format!("`confidence`: {confidence}, expected a number in (0, 1)")));
    }
    if min_iterations > max_iterations {
        return Err(Failure::Input(format!("`min_iterations` {min_iterations} exceeds `max_iterations` {max_iterations}")));
    }
    Ok(RansacOptions { threshold, max_iterations, min_iterations, confidence, seed, local_optimization, refine_rounds, skip_explained })
}

#[pymethods]
impl ProblemSolver {
    /// The problem's name.
    #[getter]
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    /// Correspondences a solve takes: exactly this many, or at least (`more_rows`).
    #[getter(rows)]
    fn row_count(&self) -> usize {
        self.fields.rows
    }

    /// Whether a solve takes more than `rows` correspondences.
    #[getter]
    fn more_rows(&self) -> bool {
        self.fields.more_rows
    }

    /// `(name, shape)` of each field of a row, in column order.
    #[getter]
    fn row_fields(&self) -> Vec<(String, Vec<usize>)> {
        described(&self.fields.row)
    }

    /// `(name, shape)` of each global field.
    #[getter]
    fn global_fields(&self) -> Vec<(String, Vec<usize>)> {
        described(&self.fields.globals)
    }

    /// `(name, shape)` of each field of a solution, in the order of `solve_batch`'s columns.
    #[getter]
    fn solution_fields(&self) -> Vec<(String, Vec<usize>)> {
        described(&self.fields.solution)
    }

    /// What the problem solves, its conventions and units.
    #[getter]
    fn about(&self) -> String {
        self.fields.about.clone()
    }

    /// Solves one instance: the correspondences as one `(N, per_row)` array of rows (fields in
    /// `row_fields` order) or one array per field, in that order or by name; `globals` the
    /// global numbers (if the problem has any); `noise` the data's noise in the problem's unit
    /// (the validator's tolerance; default: exact data). Returns a `Solution`, validated on all
    /// rows, with `certified`: the bound on the distance to an exact root that an interval
    /// Krawczyk test proved, or `None` where the proof did not go through. Raises `InputError`
    /// (naming the array, row and field) or a `SolveError`.
    #[pyo3(signature = (*arrays, globals = None, noise = None, **fields))]
    fn solve(
        &self,
        py: Python<'_>,
        arrays: &Bound<'_, PyTuple>,
        globals: Option<&Bound<'_, PyAny>>,
        noise: Option<f64>,
        fields: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Solution> {
        let (x, certified) = self.solve_any(py, arrays, globals, noise, fields).map_err(|e| self.raise(py, e))?;
        Solution::new(py, &self.fields.solution, &x, certified)
    }

    /// `solver(...)` is `solver.solve(...)`.
    #[pyo3(signature = (*arrays, globals = None, noise = None, **fields))]
    fn __call__(
        &self,
        py: Python<'_>,
        arrays: &Bound<'_, PyTuple>,
        globals: Option<&Bound<'_, PyAny>>,
        noise: Option<f64>,
        fields: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Solution> {
        self.solve(py, arrays, globals, noise, fields)
    }

    /// Solves `B` instances across cores: `rows` is `(B, N, per_row)`, `globals` `None`,
    /// `(G,)` for all or `(B, G)`. Returns `(x, ok)`: `x` is `(B, solution numbers)` in the
    /// order of `solution_fields`, each flattened (NaN where `ok` is False: that instance has no
    /// validated solution).
    #[pyo3(signature = (rows, globals = None, *, noise = 0.0))]
    fn solve_batch<'py>(
        &self,
        py: Python<'py>,
        rows: &Bound<'py, PyAny>,
        globals: Option<&Bound<'py, PyAny>>,
        noise: f64,
    ) -> PyResult<BatchResult<'py>> {
        self.batch(py, rows, globals, noise).map_err(|e| self.raise(py, e))
    }

    /// Robust estimate (LO-RANSAC, MSAC scoring on the problem's per-correspondence error) from
    /// any number of correspondences with outliers, given as to `solve`. Options are PoseLib's
    /// defaults; `threshold` is in the units of the problem's row error (a default where the
    /// problem has one, `about`); `noise` (the data's, in the problem's unit) sets how far a
    /// sample's solution may miss its own rows. Returns `(solution, info)`, `info` holding
    /// `iterations`, `num_inliers`, `inlier_ratio`, `inlier_mask` (bool array), `score`,
    /// `refinements`, `models` and `certified`. `skip_explained=True`: past the confidence,
    /// samples whose rows are all inliers of the best model are not solved (much faster with few
    /// outliers, about one point of success less at 20-40 % on GRPS).
    #[pyo3(signature = (*arrays, globals = None, threshold = None, noise = None, max_iterations = 100_000, min_iterations = 1000, confidence = 0.9999, seed = 0, local_optimization = true, refine_rounds = 2, skip_explained = false, **fields))]
    #[allow(clippy::too_many_arguments)]
    fn estimate<'py>(
        &self,
        py: Python<'py>,
        arrays: &Bound<'py, PyTuple>,
        globals: Option<&Bound<'py, PyAny>>,
        threshold: Option<f64>,
        noise: Option<f64>,
        max_iterations: usize,
        min_iterations: usize,
        confidence: f64,
        seed: u64,
        local_optimization: bool,
        refine_rounds: usize,
        skip_explained: bool,
        fields: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<(Solution, Bound<'py, PyDict>)> {
        let options = |threshold| {
            ransac_options(threshold, max_iterations, min_iterations, confidence, seed, local_optimization, refine_rounds, skip_explained)
        };
        let (x, info) = self.estimate_any(py, arrays, globals, threshold, noise, options, fields).map_err(|e| self.raise(py, e))?;
        let certified = info.certified.and_then(|c| c.ok());
        Ok((Solution::new(py, &self.fields.solution, &x, certified)?, info_dict(py, &info)?))
    }

    fn __repr__(&self) -> String {
        let f = &self.fields;
        let names = |list: &[Field]| list.iter().map(|f| f.name).collect::<Vec<_>>().join(", ");
        let count = if f.more_rows { format!("{}+", f.rows) } else { f.rows.to_string() };
        format!("<{}.ProblemSolver `{}`: {count} rows of [{}] -> [{}]>", self.module, self.inner.name(), names(&f.row), names(&f.solution))
    }
}
