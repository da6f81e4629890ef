//! All roots of a declared problem: the [`AllRoots`] hook, its implementation on a square
//! subsystem with a start system from monodromy ([`SquareSubsystem`]); the pipeline's fallback
//! over it is [`super::instance::InstanceProblem::fallback_candidates`] of the blanket impl.

use crate::all_roots::{solve_all_fast, AllRootsOptions, StartSystem};
use crate::layout::{FieldKind, Layout};
use crate::monodromy::SignFlip;
use crate::pipeline::Fallback;
use crate::start_system::{run_monodromy, MonodromyConfig, MonodromyReport, StartSystemError, StartSystemFile};
use crate::{CoefficientForm, ParamDerivative, ProblemInfo, ProblemLayout};
use nalgebra::SVector;
use std::marker::PhantomData;

/// All real solutions of a problem's data from a start system, and the monodromy run that
/// makes the start system.
pub trait AllRoots<const NX: usize, const NP: usize> {
    /// The real solutions of the square subsystem of `p` (empty without a start system).
    fn candidates(&self, p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>>;
    /// Whether a start system is loaded.
    fn has_start_system(&self) -> bool;
    /// Finds all solutions of a generic complex instance by monodromy.
    fn monodromy(&self, config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError>;
    /// The same subsystem with the start system of a `monodromy` JSON file read at run time
    /// (instead of the one built in), for [`super::InstanceSolver::with_fallback`] and the
    /// commands' `--start-system`.
    fn with_start_system(&self, json: &str) -> Result<Box<dyn AllRoots<NX, NP> + Send + Sync>, StartSystemError>;
}

/// The all-roots fallback of row-wise data over an [`AllRoots`] (a [`SquareSubsystem`], say,
/// with a start system read at run time): [`super::InstanceSolver::with_fallback`].
pub struct AllRootsFallback<const NX: usize, const ND: usize>(pub Box<dyn AllRoots<NX, ND> + Send + Sync>);

impl<const NX: usize, const ND: usize> AllRootsFallback<NX, ND> {
    /// The fallback over `all_roots`.
    pub fn new(all_roots: impl AllRoots<NX, ND> + Send + Sync + 'static) -> Self {
        Self(Box::new(all_roots))
    }
}

impl<const NX: usize, const ND: usize, const NP: usize> Fallback<SVector<f64, ND>, NX, NP> for AllRootsFallback<NX, ND> {
    /// The subsystem's roots of the data (as the problem's own fallback solves them).
    fn candidates(&self, data: &SVector<f64, ND>, _p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>> {
        self.0.candidates(data)
    }
}

/// The square subsystem `Q` of a problem: its first `Q::LAYOUT.rows` rows and the global
/// parameters (for example 6 of 7 correspondences), with a start system from `monodromy`.
pub struct SquareSubsystem<Q, const NX: usize, const NQ: usize, const NCQ: usize> {
    start: Option<StartSystem<NX, NQ>>,
    expected: Option<usize>,
    /// Settings of the all-roots solve.
    pub options: AllRootsOptions,
    problem: PhantomData<fn() -> Q>,
}

impl<Q, const NX: usize, const NQ: usize, const NCQ: usize> SquareSubsystem<Q, NX, NQ, NCQ>
where
    Q: CoefficientForm<NX, NX, NQ, NCQ> + ParamDerivative<NX, NX, NQ> + ProblemLayout + ProblemInfo,
{
    /// The subsystem with the start system of a `monodromy` JSON file (`None`: not made yet;
    /// then only `monodromy` works). `expected` is the solution count from theory, if known
    /// (modulo the quaternion sign), for the monodromy report.
    pub fn new(start_json: Option<&str>, expected: Option<usize>) -> Result<Self, StartSystemError> {
        let start = start_json.map(|text| StartSystemFile::from_json(text).and_then(|f| f.start_system::<NX, NQ>())).transpose()?;
        Ok(Self { start, expected, options: AllRootsOptions::default(), problem: PhantomData })
    }
}

/// The sign symmetry `q -> -q` of the first quaternion unknown, if any.
fn quaternion_symmetry(layout: &Layout) -> Option<SignFlip> {
    layout.unknowns.iter().find(|f| f.kind == FieldKind::Quat).map(|f| SignFlip::new((f.offset..f.offset + 4).collect::<Vec<_>>()))
}

impl<Q, const NX: usize, const NQ: usize, const NCQ: usize, const NP: usize> AllRoots<NX, NP> for SquareSubsystem<Q, NX, NQ, NCQ>
where
    Q: CoefficientForm<NX, NX, NQ, NCQ> + ParamDerivative<NX, NX, NQ> + ProblemLayout + ProblemInfo + 'static,
{
    fn candidates(&self, p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>> {
        let Some(start) = &self.start else { return Vec::new() };
        let Some(q) = Q::LAYOUT.first_rows::<NQ>(p.as_slice()) else { return Vec::new() };
        solve_all_fast::<Q, NX, NQ, NCQ>(start, &q, &self.options).real.iter().map(|s| s.x).collect()
    }

    fn has_start_system(&self) -> bool {
        self.start.is_some()
    }

    fn monodromy(&self, config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError> {
        let layout = Q::LAYOUT;
        let fields: Vec<&str> = layout.row.iter().map(|f| f.name).collect();
        let description = format!(
            "{} rows of {} scalars [{}], then {} global scalars, as {}::params",
            layout.rows,
            layout.per_row,
            fields.join(", "),
            layout.globals_len(),
            Q::NAME
        );
        run_monodromy::<Q, NX, NQ>(config, quaternion_symmetry(&layout), &description, self.expected)
    }

    fn with_start_system(&self, json: &str) -> Result<Box<dyn AllRoots<NX, NP> + Send + Sync>, StartSystemError> {
        let mut other = Self::new(Some(json), self.expected)?;
        other.options = self.options;
        Ok(Box::new(other))
    }
}
