//! Any problem as a Python object: its solver behind an object-safe trait ([`DynSolver`]), so
//! one Python class ([`ProblemSolver`], `crate::class`) serves every problem: a declared
//! problem's library solver ([`simhc::solver::Solver`], any data as rows), and the built-ins,
//! which register their own [`DynSolver`] for their correspondences ([`register`]).
//! [`add_problem`] / [`crate::python_module!`] put a declared problem in a module, with
//! exceptions and help named for that module.

use crate::class::ProblemSolver;
use crate::errors::{Exceptions, Failure};
use nalgebra::SVector;
use pyo3::prelude::*;
use rayon::prelude::*;
use simhc::layout::{FieldKind, FieldLayout, Layout};
use simhc::ransac::RansacOptions;
use simhc::solver::library::Check;
use simhc::solver::{DeclaredProblem, EstimateError, EstimateInfo, SolveError, Solver};
use simhc::ProblemLayout;
use std::sync::Arc;

/// A named field of a problem's data or solution, as numpy sees it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// Its name: a keyword argument (data) or key (solution).
    pub name: &'static str,
    /// The shape of one value: `[]` a scalar, `[3]` a vector, `[3, 3]` a matrix.
    pub shape: Vec<usize>,
    /// Data only: zeros when not given (UPnP's `origins`: one central camera at the origin).
    pub optional: bool,
}

impl Field {
    /// A field that must be given.
    pub fn new(name: &'static str, shape: &[usize]) -> Self {
        Self { name, shape: shape.to_vec(), optional: false }
    }

    /// A field that is zeros when not given.
    pub fn optional(name: &'static str, shape: &[usize]) -> Self {
        Self { optional: true, ..Self::new(name, shape) }
    }

    /// Numbers the field occupies.
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }

    /// A field of no numbers (never: every field holds at least one).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// A declared field (`simhc::layout`): a symmetric matrix is its stored upper triangle.
    fn declared(f: &FieldLayout) -> Self {
        let shape = match f.kind {
            FieldKind::Scalar => vec![],
            FieldKind::Matrix(r, c) => vec![r, c],
            kind => vec![kind.len()],
        };
        Self { name: f.name, shape, optional: false }
    }
}

/// Numbers in a list of fields.
pub fn fields_len(fields: &[Field]) -> usize {
    fields.iter().map(Field::len).sum()
}

/// How a problem's data and solution look from Python, and its estimator's defaults.
#[derive(Debug, Clone)]
pub struct Fields {
    /// The fields of one correspondence (a row), in column order.
    pub row: Vec<Field>,
    /// The fields given once per instance.
    pub globals: Vec<Field>,
    /// The fields of a solution, in the order of `solve_batch`'s columns.
    pub solution: Vec<Field>,
    /// Correspondences a solve takes: exactly this many, or at least (`more_rows`).
    pub rows: usize,
    /// Whether a solve takes more than `rows` correspondences.
    pub more_rows: bool,
    /// The estimator's inlier threshold when the caller gives none (`None`: the caller must).
    pub threshold: Option<f64>,
    /// The data's noise the estimator assumes when the caller gives none.
    pub estimate_noise: f64,
    /// What the problem solves, its conventions and units, for help.
    pub about: String,
}

/// A problem's solver without its sizes in the type: what the Python class calls. Rows come
/// as `n` correspondences of `fields().row` numbers each, row-major; a solution goes back as
/// the numbers of `fields().solution`.
pub trait DynSolver: Send + Sync {
    /// The problem's name.
    fn name(&self) -> &'static str;
    /// The fields of its data and solution.
    fn fields(&self) -> Fields;
    /// One solve of `n` rows (the count already checked against `fields()`): the validated
    /// solution and the error bound of its certificate (`None`: not certified).
    fn solve(&self, n: usize, rows: &[f64], globals: &[f64]) -> Result<(Vec<f64>, Option<f64>), Failure>;
    /// Solves of `rows.len() / (n * per_row)` instances of `n` rows each, `globals` holding
    /// each one's, across rayon's threads.
    fn solve_batch(&self, n: usize, rows: &[f64], globals: &[f64]) -> Vec<Result<Vec<f64>, Failure>> {
        let f = self.fields();
        let (per, g) = (n * fields_len(&f.row), fields_len(&f.globals));
        let count = rows.len().checked_div(per).unwrap_or(0);
        if globals.len() != count * g {
            return vec![Err(Failure::Input(format!("`globals`: {} numbers for {count} instances of {g}", globals.len()))); count];
        }
        (0..count)
            .into_par_iter()
            .map(|i| self.solve(n, &rows[i * per..(i + 1) * per], &globals[i * g..(i + 1) * g]).map(|(x, _)| x))
            .collect()
    }
    /// The robust estimate from any number of rows with outliers.
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

/// The library estimator's error as a [`Failure`]: bad input, or no model.
pub fn estimate_failure(e: EstimateError) -> Failure {
    match e {
        EstimateError::NoModel { .. } | EstimateError::NotSolved { .. } => Failure::NoSolution(e.to_string()),
        _ => Failure::Input(e.to_string()),
    }
}

/// A declared problem: its rows are its data instance's rows, its solution its unknowns.
impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> DynSolver for Solver<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
    Self: Send + Sync,
{
    fn name(&self) -> &'static str {
        S::NAME
    }
    fn fields(&self) -> Fields {
        let layout = S::Data::LAYOUT;
        let declared = |list: &[FieldLayout]| list.iter().map(Field::declared).collect();
        Fields {
            row: declared(layout.row),
            globals: declared(layout.globals),
            solution: declared(layout.unknowns),
            rows: layout.rows,
            more_rows: false,
            threshold: None,
            estimate_noise: 0.0,
            about: about(S::NAME, &layout),
        }
    }
    fn solve(&self, n: usize, rows: &[f64], globals: &[f64]) -> Result<(Vec<f64>, Option<f64>), Failure> {
        if rows.len() + globals.len() != ND {
            let (per_row, g) = (S::Data::LAYOUT.per_row, S::Data::LAYOUT.globals_len());
            return Err(Failure::Input(format!(
                "{n} rows and {} global numbers: `{}` takes {} rows of {per_row} and {g}",
                globals.len(),
                S::NAME,
                S::Data::LAYOUT.rows
            )));
        }
        let p = SVector::<f64, ND>::from_iterator(rows.iter().chain(globals).copied());
        Solver::solve(self, &p)
            .map(|s| (s.x.as_slice().to_vec(), s.certified.and_then(|c| c.ok()).map(|c| c.error_bound())))
            .map_err(solve_failure)
    }
    fn estimate(&self, rows: &[f64], globals: &[f64], options: &RansacOptions) -> Result<(Vec<f64>, EstimateInfo), Failure> {
        Solver::estimate(self, (rows, globals), options).map(|(x, info)| (x.as_slice().to_vec(), info)).map_err(estimate_failure)
    }
}

/// What a declared problem's solver takes and gives.
fn about(problem: &str, layout: &Layout) -> String {
    let names = |f: &[FieldLayout]| f.iter().map(|f| format!("{} ({})", f.name, f.kind.len())).collect::<Vec<_>>().join(", ");
    let globals = if layout.globals.is_empty() { String::new() } else { format!(", globals: {}", names(layout.globals)) };
    format!(
        "`{problem}`: {rows} correspondences per solve. A row is [{row}]{globals}; the unknowns are {unknowns}. \
         `noise` is the data's, in the problem's unit (the validator's tolerance); `estimate` needs `threshold`, \
         in the unit of the problem's row error.",
        rows = layout.rows,
        row = names(layout.row),
        unknowns = names(layout.unknowns),
    )
}

/// Builds a problem's solver for data with noise of the given size (the validator's tolerance).
pub type MakeSolver = Box<dyn Fn(f64) -> Result<Arc<dyn DynSolver>, String> + Send + Sync>;

/// Registers a problem in module `m` as the [`ProblemSolver`] `m.<name>`: `make(noise)` builds
/// its solver (the one for exact data at once), `exceptions` are the module's. Every problem,
/// a built-in or a user's, reaches Python this way.
pub fn register<'py>(
    m: &Bound<'py, PyModule>,
    name: &str,
    make: MakeSolver,
    exceptions: Arc<Exceptions>,
) -> PyResult<Bound<'py, ProblemSolver>> {
    let py = m.py();
    let module = public_name(&m.name()?.to_string()).to_string();
    let solver = ProblemSolver::new(make, exceptions, &module).map_err(pyo3::exceptions::PyRuntimeError::new_err)?;
    let object = Bound::new(py, solver)?;
    m.add_class::<ProblemSolver>()?;
    m.add_class::<crate::solution::Solution>()?;
    // The classes are this module's (one type object per extension module).
    py.get_type::<ProblemSolver>().setattr("__module__", &module)?;
    py.get_type::<crate::solution::Solution>().setattr("__module__", &module)?;
    m.add(name, &object)?;
    Ok(object)
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
    add_solver(m, Box::new(make))
}

/// Puts any problem's solver in a Python module, as [`add_problem`] does a declared one's:
/// `make(noise)` builds its [`DynSolver`] (data of any type, given to Python as named fields).
pub fn add_solver<'py>(m: &Bound<'py, pyo3::types::PyModule>, make: MakeSolver) -> PyResult<Bound<'py, ProblemSolver>> {
    let module = public_name(&m.name()?.to_string()).to_string();
    let exceptions = Arc::new(Exceptions::new(m.py(), &module)?);
    exceptions.add_to(m)?;
    let object = register(m, "solver", make, exceptions)?;
    for name in ["solve", "solve_batch", "estimate"] {
        m.add(name, object.getattr(name)?)?;
    }
    m.setattr("__doc__", module_doc(&module, object.get().fields()))?;
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
fn module_doc(module: &str, fields: &Fields) -> String {
    let per_row = fields_len(&fields.row);
    let count = if fields.more_rows { format!("{} or more", fields.rows) } else { format!("exactly {}", fields.rows) };
    format!(
        "{module}: the simhc solver of {about}\n\n\
         - {module}.solve(rows, globals=None, *, noise=None): one instance of {count} rows (or the fields by\n  \
         name), a Solution of the validated solution fields and `certified`.\n\
         - {module}.estimate(rows, globals=None, *, threshold, ...): robust (LO-RANSAC), any number of rows with\n  \
         outliers; returns (solution, info).\n\
         - {module}.solve_batch(rows, globals=None, *, noise=0.0): (B, N, {per_row}) rows across cores; returns (x, ok).\n\
         - {module}.solver: the {module}.ProblemSolver behind them.\n\n\
         Errors: {module}.InputError (a ValueError naming the row and field), {module}.SolveError (a\n\
         RuntimeError) with {module}.NotValidatedError and {module}.NoSolutionError.",
        about = fields.about,
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
///
/// Data of another type (UPnP's correspondences): implement [`DynSolver`] and give the function
/// that builds it for a noise level, `python_module!(focal, solver = my_solver)` with
/// `fn my_solver(noise: f64) -> Result<Arc<dyn DynSolver>, String>` ([`add_solver`]; the
/// built-ins of the `simhc` wheel are two such solvers, `python/src/builtin.rs`).
#[macro_export]
macro_rules! python_module {
    ($module:ident, solver = $make:expr) => {
        #[$crate::pyo3::pymodule]
        #[pyo3(crate = "::simhc_pymodule::pyo3")]
        pub fn $module(m: &$crate::pyo3::Bound<'_, $crate::pyo3::types::PyModule>) -> $crate::pyo3::PyResult<()> {
            $crate::add_solver(m, ::std::boxed::Box::new($make)).map(|_| ())
        }
    };
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
