//! Any declared problem as a Python object: its library solver
//! ([`simhc::solver::Solver`]) behind an object-safe trait ([`DynSolver`]), so one Python class
//! ([`ProblemSolver`]) serves every problem, and [`add_problem`] / [`crate::python_module!`]
//! put it in a module, with exceptions and help named for that module.

use crate::arrays::{float_array, shape_text};
use crate::errors::{Error, Exceptions, Failure};
use nalgebra::SVector;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use simhc::layout::{FieldKind, FieldLayout, Layout};
use simhc::ransac::RansacOptions;
use simhc::solver::library::Check;
use simhc::solver::{DeclaredProblem, EstimateError, EstimateInfo, SolveError, Solver};
use simhc::ProblemLayout;
use std::sync::{Arc, Mutex};

/// A declared problem's solver without its sizes in the type: what the Python class calls.
pub trait DynSolver: Send + Sync {
    /// The problem's name (`DeclaredProblem::NAME`).
    fn name(&self) -> &'static str;
    /// The layout of the data instance (rows, fields, unknowns).
    fn layout(&self) -> Layout;
    /// One solve of the data's parameter vector (`layout().param_len()` numbers): the
    /// validated unknowns.
    fn solve(&self, params: &[f64]) -> Result<(Vec<f64>, Option<f64>), Failure>;
    /// Solves of `params.len() / layout().param_len()` instances across cores.
    fn solve_batch(&self, params: &[f64]) -> Vec<Result<Vec<f64>, Failure>>;
    /// The robust estimate from any number of rows.
    fn estimate(&self, rows: &[f64], globals: &[f64], options: &RansacOptions) -> Result<(Vec<f64>, EstimateInfo), Failure>;
}

/// A library solve's error as a [`Failure`]: bad input, no validated end point, or none.
pub fn solve_failure<C: std::fmt::Debug, const NX: usize>(e: SolveError<C, NX>) -> Failure {
    match e {
        SolveError::Input(_) => Failure::Input(e.to_string()),
        SolveError::NotValidated { .. } | SolveError::NotCertified { .. } => Failure::NotValidated(e.to_string()),
        SolveError::NoEndPoint { .. } => Failure::NoSolution(e.to_string()),
    }
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> DynSolver for Solver<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
    Self: Send + Sync,
    // A batch's results cross threads.
    Check<S::Validator, NX, ND>: Send,
{
    fn name(&self) -> &'static str {
        S::NAME
    }
    fn layout(&self) -> Layout {
        S::Data::LAYOUT
    }
    fn solve(&self, params: &[f64]) -> Result<(Vec<f64>, Option<f64>), Failure> {
        let p = SVector::<f64, ND>::from_column_slice(params);
        Solver::solve(self, &p)
            .map(|s| (s.x.as_slice().to_vec(), s.certified.and_then(|c| c.ok()).map(|c| c.error_bound())))
            .map_err(solve_failure)
    }
    fn solve_batch(&self, params: &[f64]) -> Vec<Result<Vec<f64>, Failure>> {
        let data: Vec<SVector<f64, ND>> = params.chunks_exact(ND).map(SVector::from_column_slice).collect();
        Solver::solve_batch(self, &data).into_iter().map(|r| r.map(|s| s.x.as_slice().to_vec()).map_err(solve_failure)).collect()
    }
    fn estimate(&self, rows: &[f64], globals: &[f64], options: &RansacOptions) -> Result<(Vec<f64>, EstimateInfo), Failure> {
        Solver::estimate(self, (rows, globals), options).map(|(x, info)| (x.as_slice().to_vec(), info)).map_err(|e| match e {
            EstimateError::NoModel { .. } | EstimateError::NotSolved { .. } => Failure::NoSolution(e.to_string()),
            _ => Failure::Input(e.to_string()),
        })
    }
}

/// Builds a problem's solver for data with noise of the given size (the validator's tolerance).
pub type MakeSolver = Box<dyn Fn(f64) -> Result<Arc<dyn DynSolver>, String> + Send + Sync>;

/// `solve_batch`'s `(x, ok)`.
pub type BatchResult<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<bool>>);

/// A declared problem's solver, built once when its module is imported.
///
/// `solve(rows, globals=None)` takes exactly `rows` correspondences as a `(rows, per_row)`
/// array, fields in the order of `row_fields`; `estimate(rows, ..., threshold=..)` takes any
/// number of them, with outliers; `solve_batch` takes `(B, rows, per_row)`. Unknowns come back
/// by name (`unknowns`). Errors are the module's `InputError` and `SolveError`.
// `__module__` is set to the user's module when it is imported (`add_problem`).
#[pyclass(module = "simhc_pymodule", frozen)]
pub struct ProblemSolver {
    /// The solver for exact data (noise 0).
    inner: Arc<dyn DynSolver>,
    /// The solver whose validator allows data with noise `noise` (the problem's unit).
    make: MakeSolver,
    /// Solvers made for other noise levels, by the noise's bits.
    noisy: Mutex<Vec<(u64, Arc<dyn DynSolver>)>>,
    /// The module's exception types.
    exceptions: Exceptions,
    /// The module's name, for `repr`.
    module: String,
}

fn fields(list: &[FieldLayout]) -> Vec<(String, usize)> {
    list.iter().map(|f| (f.name.to_string(), f.kind.len())).collect()
}

impl ProblemSolver {
    /// The Python object of a problem in module `module`: `make(noise)` builds its solver for
    /// data with noise of size `noise` (the validator's tolerance); the one for exact data is
    /// built at once. Its errors are raised as `exceptions`.
    pub fn new(make: MakeSolver, exceptions: Exceptions, module: &str) -> Result<Self, String> {
        Ok(Self { inner: make(0.0)?, make, noisy: Mutex::new(Vec::new()), exceptions, module: module.to_string() })
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

    /// The global numbers: `None` or an array of `globals_len()` numbers.
    fn globals(&self, globals: Option<&Bound<'_, PyAny>>) -> Result<Vec<f64>, Error> {
        let expected = self.inner.layout().globals_len();
        let values = match globals {
            Some(g) => float_array(g, "globals")?.1,
            None => Vec::new(),
        };
        if values.len() != expected {
            return Err(Failure::Input(format!("`globals`: {} numbers, the problem has {expected}", values.len())).into());
        }
        Ok(values)
    }

    /// The unknowns by field name: a float for a scalar, an array otherwise.
    fn unknowns_dict<'py>(&self, py: Python<'py>, x: &[f64]) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for f in self.inner.layout().unknowns {
            let values = &x[f.offset..f.offset + f.kind.len()];
            if f.kind == FieldKind::Scalar {
                dict.set_item(f.name, values[0])?;
            } else {
                dict.set_item(f.name, PyArray1::from_slice(py, values))?;
            }
        }
        Ok(dict)
    }

    /// The row-major rows of a `(N, per_row)` array.
    fn rows(&self, rows: &Bound<'_, PyAny>) -> Result<(usize, Vec<f64>), Error> {
        let per_row = self.inner.layout().per_row;
        let (shape, data) = float_array(rows, "rows")?;
        match shape.as_slice() {
            [n, w] if *w == per_row => Ok((*n, data)),
            _ => Err(Failure::Input(format!("`rows`: expected an array of shape (N, {per_row}), got shape {}", shape_text(&shape))).into()),
        }
    }

    /// The validated unknowns of exactly `layout().rows` rows with noise `noise`, and the
    /// error bound of their certificate (`None`: not certified).
    fn solve_rows(
        &self,
        py: Python<'_>,
        n: usize,
        rows: Vec<f64>,
        globals: Vec<f64>,
        noise: f64,
    ) -> Result<(Vec<f64>, Option<f64>), Error> {
        let layout = self.inner.layout();
        if n != layout.rows {
            return Err(Failure::Input(format!(
                "{n} correspondences: `{}` solves exactly {} (use `estimate` for more, with outliers)",
                self.inner.name(),
                layout.rows
            ))
            .into());
        }
        let mut params = rows;
        params.extend_from_slice(&globals);
        let solver = self.solver(noise)?;
        Ok(py.detach(|| solver.solve(&params))?)
    }

    /// The robust estimate with its info.
    fn estimate_rows(
        &self,
        py: Python<'_>,
        rows: Vec<f64>,
        globals: Vec<f64>,
        options: &RansacOptions,
        noise: f64,
    ) -> Result<(Vec<f64>, EstimateInfo), Error> {
        let solver = self.solver(noise)?;
        Ok(py.detach(|| solver.estimate(&rows, &globals, options))?)
    }

    /// `solve_batch` before its errors are raised.
    fn batch<'py>(
        &self,
        py: Python<'py>,
        rows: &Bound<'py, PyAny>,
        globals: Option<&Bound<'py, PyAny>>,
        noise: f64,
    ) -> Result<BatchResult<'py>, Error> {
        let layout = self.inner.layout();
        let (shape, data) = float_array(rows, "rows")?;
        let b = match shape.as_slice() {
            [b, n, w] if *n == layout.rows && *w == layout.per_row => *b,
            _ => {
                return Err(Failure::Input(format!(
                    "`rows`: expected an array of shape (B, {}, {}), got shape {}",
                    layout.rows,
                    layout.per_row,
                    shape_text(&shape)
                ))
                .into());
            }
        };
        let g = layout.globals_len();
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
        let per = layout.rows * layout.per_row;
        let mut params = Vec::with_capacity(b * (per + g));
        for i in 0..b {
            params.extend_from_slice(&data[i * per..(i + 1) * per]);
            params.extend_from_slice(&all_globals[i * g..(i + 1) * g]);
        }
        let solver = self.solver(noise)?;
        let results = py.detach(|| solver.solve_batch(&params));
        let nx = layout.unknown_len();
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
    Ok(RansacOptions {
        threshold,
        max_iterations,
        min_iterations,
        confidence,
        seed,
        local_optimization,
        refine_rounds,
        skip_explained: false,
    })
}

#[pymethods]
impl ProblemSolver {
    /// The problem's name.
    #[getter]
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    /// Correspondences per solve.
    #[getter(rows)]
    fn row_count(&self) -> usize {
        self.inner.layout().rows
    }

    /// `(name, length)` of each field of a row, in column order.
    #[getter]
    fn row_fields(&self) -> Vec<(String, usize)> {
        fields(self.inner.layout().row)
    }

    /// `(name, length)` of each global field.
    #[getter]
    fn global_fields(&self) -> Vec<(String, usize)> {
        fields(self.inner.layout().globals)
    }

    /// `(name, length)` of each unknown, in the order of `solve_batch`'s columns.
    #[getter]
    fn unknowns(&self) -> Vec<(String, usize)> {
        fields(self.inner.layout().unknowns)
    }

    /// Solves one instance: `rows` is a `(rows, per_row)` array (fields in `row_fields`
    /// order), `globals` the global numbers (if the problem has any), `noise` the data's noise
    /// in the problem's unit (the validator's tolerance; 0: exact data). Returns the unknowns
    /// by name, validated on all rows, and `"certified"`: the bound on the distance to an
    /// exact root that an interval Krawczyk test proved, or `None` where the proof did not go
    /// through; raises `InputError` (naming the row and field) or a `SolveError`.
    #[pyo3(signature = (rows, globals = None, *, noise = 0.0))]
    fn solve<'py>(
        &self,
        py: Python<'py>,
        rows: &Bound<'py, PyAny>,
        globals: Option<&Bound<'py, PyAny>>,
        noise: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (x, certified) = (|| {
            let (n, rows) = self.rows(rows)?;
            let globals = self.globals(globals)?;
            self.solve_rows(py, n, rows, globals, noise)
        })()
        .map_err(|e| self.raise(py, e))?;
        let dict = self.unknowns_dict(py, &x)?;
        dict.set_item("certified", certified)?;
        Ok(dict)
    }

    /// Solves `B` instances across cores: `rows` is `(B, rows, per_row)`, `globals` `None`,
    /// `(G,)` for all or `(B, G)`. Returns `(x, ok)`: `x` is `(B, unknowns)` in the order of
    /// `unknowns` (NaN where `ok` is False: that instance has no validated solution).
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
    /// any number of rows with outliers: `rows` is `(N, per_row)`. Options are PoseLib's
    /// defaults; `threshold` is in the units of the problem's row error, `noise` (the data's,
    /// in the problem's unit) sets how far a sample's solution may miss its own rows. Returns
    /// `(unknowns, info)`, `info` holding `iterations`, `num_inliers`, `inlier_ratio`,
    /// `inlier_mask` (bool array), `score`, `refinements` and `models`. `skip_explained=True`:
    /// past the confidence, samples whose rows are all inliers of the best model are not solved
    /// (much faster with few outliers, about one point of success less at 20-40 %).
    #[pyo3(signature = (rows, globals = None, *, threshold, noise = 0.0, max_iterations = 100_000, min_iterations = 1000, confidence = 0.9999, seed = 0, local_optimization = true, refine_rounds = 2, skip_explained = false))]
    #[allow(clippy::too_many_arguments)]
    fn estimate<'py>(
        &self,
        py: Python<'py>,
        rows: &Bound<'py, PyAny>,
        globals: Option<&Bound<'py, PyAny>>,
        threshold: f64,
        noise: f64,
        max_iterations: usize,
        min_iterations: usize,
        confidence: f64,
        seed: u64,
        local_optimization: bool,
        refine_rounds: usize,
        skip_explained: bool,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let (x, info) = (|| {
            let options = ransac_options(threshold, max_iterations, min_iterations, confidence, seed, local_optimization, refine_rounds)?
                .skipping_explained(skip_explained);
            let (_, rows) = self.rows(rows)?;
            let globals = self.globals(globals)?;
            self.estimate_rows(py, rows, globals, &options, noise)
        })()
        .map_err(|e| self.raise(py, e))?;
        Ok((self.unknowns_dict(py, &x)?, info_dict(py, &info)?))
    }

    fn __repr__(&self) -> String {
        let l = self.inner.layout();
        let names = |f: &[FieldLayout]| f.iter().map(|f| f.name).collect::<Vec<_>>().join(", ");
        format!("<{}.solver `{}`: {} rows of [{}] -> [{}]>", self.module, self.inner.name(), l.rows, names(l.row), names(l.unknowns))
    }
}

/// Puts a declared problem in a Python module: its solver as `solver`, and `solve`,
/// `solve_batch`, `estimate` as module functions, with the exception types and the module's
/// help, all named for the module (`gen_relpose.InputError`, `help(gen_relpose)`).
pub fn add_problem<'py, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(
    m: &Bound<'py, pyo3::types::PyModule>,
    problem: S,
) -> PyResult<Bound<'py, ProblemSolver>>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND> + Send + Sync,
    Solver<S, NX, NF, NP, NC, ND>: Send + Sync,
    Check<S::Validator, NX, ND>: Send,
{
    let weights =
        problem.weights().ok_or_else(|| pyo3::exceptions::PyRuntimeError::new_err(format!("{} has no shipped weights", S::NAME)))?;
    let problem = Arc::new(problem);
    let make = move |noise: f64| -> Result<Arc<dyn DynSolver>, String> {
        // From Python a call costs tens of microseconds already: solutions carry their
        // certificate (`x["certified"]`).
        let solver = Solver::with_shared(problem.clone(), weights, noise)
            .map_err(|e| format!("{}: {e}", S::NAME))?
            .certifying(simhc::solver::Certification::Report);
        Ok(Arc::new(solver))
    };
    let py = m.py();
    let module = public_name(&m.name()?.to_string()).to_string();
    let exceptions = Exceptions::new(py, &module)?;
    exceptions.add_to(m)?;
    let solver = ProblemSolver::new(Box::new(make), exceptions, &module).map_err(pyo3::exceptions::PyRuntimeError::new_err)?;
    let layout = solver.inner.layout();
    let object = Bound::new(py, solver)?;
    m.add_class::<ProblemSolver>()?;
    // The class is this module's (one type object per extension module).
    py.get_type::<ProblemSolver>().setattr("__module__", &module)?;
    m.add("solver", &object)?;
    for name in ["solve", "solve_batch", "estimate"] {
        m.add(name, object.getattr(name)?)?;
    }
    m.setattr("__doc__", module_doc(&module, S::NAME, &layout))?;
    Ok(object)
}

/// The name a user imports for an extension module named `name`: maturin installs a crate's
/// module `m` as the package `m` holding the extension `m.m` (its `__init__` re-exports it),
/// and a package's private extension is `package._name`; both are imported as the package.
pub fn public_name(name: &str) -> &str {
    match name.rsplit_once('.') {
        Some((package, last)) if last.starts_with('_') || package.rsplit('.').next() == Some(last) => package,
        _ => name,
    }
}

/// The help of a problem's module: what it solves and the names it holds.
fn module_doc(module: &str, problem: &str, layout: &Layout) -> String {
    let names = |f: &[FieldLayout]| f.iter().map(|f| format!("{} ({})", f.name, f.kind.len())).collect::<Vec<_>>().join(", ");
    let globals = if layout.globals.is_empty() { String::new() } else { format!(", globals: {}", names(layout.globals)) };
    format!(
        "{module}: the simhc solver of `{problem}`, {rows} correspondences per solve.\n\n\
         A row is [{row}]{globals}; the unknowns are {unknowns}.\n\n\
         - {module}.solve(rows, globals=None, *, noise=0.0): one instance of exactly {rows} rows, a dict of the\n  \
         validated unknowns and `certified`.\n\
         - {module}.estimate(rows, globals=None, *, threshold, ...): robust (LO-RANSAC), any number of rows with\n  \
         outliers; returns (unknowns, info).\n\
         - {module}.solve_batch(rows, globals=None, *, noise=0.0): (B, {rows}, {per_row}) rows across cores; returns (x, ok).\n\
         - {module}.solver: the {module}.ProblemSolver behind them.\n\n\
         Errors: {module}.InputError (a ValueError naming the row and field), {module}.SolveError (a\n\
         RuntimeError) with {module}.NotValidatedError and {module}.NoSolutionError.",
        rows = layout.rows,
        per_row = layout.per_row,
        row = names(layout.row),
        unknowns = names(layout.unknowns),
    )
}

/// A Python module for a declared problem, in one line of a user's crate (a `cdylib` built by
/// maturin):
///
/// ```ignore
/// simhc_pymodule::python_module!(gen_relpose, generalized_relative_pose::GenRelPose::new());
/// ```
///
/// gives `import gen_relpose; gen_relpose.solve(rows)`, `gen_relpose.estimate(rows,
/// threshold=..)`, `gen_relpose.solve_batch(rows)`, `gen_relpose.solver` ([`ProblemSolver`])
/// and the exceptions `gen_relpose.InputError`, `gen_relpose.SolveError`,
/// `gen_relpose.NotValidatedError`, `gen_relpose.NoSolutionError` (named by [`public_name`]).
/// The solver is built once, at import. The crate must depend on `simhc-pymodule` under that
/// name. Do not name a module after one of the standard library's (`grp` is Unix groups):
/// Python finds that one first.
#[macro_export]
macro_rules! python_module {
    ($module:ident, $problem:expr) => {
        #[$crate::pyo3::pymodule]
        #[pyo3(crate = "::simhc_pymodule::pyo3")]
        pub fn $module(m: &$crate::pyo3::Bound<'_, $crate::pyo3::types::PyModule>) -> $crate::pyo3::PyResult<()> {
            $crate::add_problem(m, $problem).map(|_| ())
        }
    };
}

#[cfg(test)]
mod tests {
    use super::public_name;

    #[test]
    fn the_public_name_is_the_package_that_re_exports_the_extension() {
        assert_eq!(public_name("gen_relpose.gen_relpose"), "gen_relpose");
        assert_eq!(public_name("simhc._simhc"), "simhc");
        assert_eq!(public_name("grp"), "grp");
        assert_eq!(public_name("vision.solvers.focal"), "vision.solvers.focal");
        assert_eq!(public_name("vision.focal.focal"), "vision.focal");
    }
}
