//! The parts a solve is assembled from: the tracked parameters of the data ([`FirstRows`]),
//! random starts for any layout ([`RandomStart`]) and a problem's canonical frame as the
//! pipeline's ([`Canon`]); the learned start refined on all rows is
//! [`super::instance::RefinedStart`].

use super::problem::{CanonicalFrame, DeclaredProblem, DegenerateInput};
use crate::layout::{FieldKind, Layout};
use crate::pipeline::learned::NonFiniteParameter;
use crate::pipeline::{Canonicalize, StartError, StartProvider, TargetParameters};
use crate::ProblemLayout;
use nalgebra::SVector;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::cell::RefCell;
use std::marker::PhantomData;

/// A problem's [`DeclaredProblem::canonicalize`] as the pipeline's [`Canonicalize`].
pub struct Canon<'a, S, const NF: usize, const NP: usize, const NC: usize>(pub &'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Canonicalize<SVector<f64, ND>, NX>
    for Canon<'_, S, NF, NP, NC>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    type Frame = CanonicalFrame<NX>;
    type Canonical = SVector<f64, ND>;
    fn canonicalize(&self, data: &SVector<f64, ND>) -> Option<(CanonicalFrame<NX>, SVector<f64, ND>)> {
        // A frame that turns finite data into NaN or infinity (degenerate data) is not used:
        // the data is solved as given, and the validator decides.
        self.0.canonicalize(data).filter(|(p, _)| p.iter().all(|v| v.is_finite())).map(|(p, frame)| (frame, p))
    }
    fn to_user(&self, frame: &CanonicalFrame<NX>, x: &SVector<f64, NX>) -> SVector<f64, NX> {
        frame.to_user(x)
    }
}

/// The tracked parameters of the data: its first `Q::LAYOUT.rows` rows and its globals. The
/// data is checked before ([`super::Solver::run_pipeline`] names the row and field of a NaN in
/// the user's data, before a canonical frame mixes the rows).
pub struct FirstRows<Q>(PhantomData<fn() -> Q>);

impl<Q: ProblemLayout> FirstRows<Q> {
    /// The first rows of the data.
    pub fn new() -> Self {
        Self(PhantomData)
    }
}

impl<Q: ProblemLayout> Default for FirstRows<Q> {
    fn default() -> Self {
        Self::new()
    }
}

/// Why [`FirstRows`] cannot make the tracked parameters, or the data is not a problem instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FirstRowsError {
    /// A parameter of the user's data is NaN or infinite.
    #[error(transparent)]
    NonFinite(#[from] NonFiniteParameter),
    /// The data is degenerate ([`DeclaredProblem::check_input`]).
    #[error(transparent)]
    Degenerate(#[from] DegenerateInput),
    /// Fewer correspondences than the problem needs.
    #[error("too few correspondences: got {got}, need at least {need}")]
    TooFew {
        /// Correspondences given.
        got: usize,
        /// Correspondences needed.
        need: usize,
    },
    /// The tracked instance is not a first-rows part of the data.
    #[error("the tracked instance has {tracked} parameters, which are not the first rows and the globals of the data's {data}")]
    Sizes {
        /// Parameters of the tracked instance.
        tracked: usize,
        /// Parameters of the data.
        data: usize,
    },
}

impl<Q: ProblemLayout, const NP: usize, const ND: usize> TargetParameters<SVector<f64, ND>, NP> for FirstRows<Q> {
    type Error = FirstRowsError;
    fn params(&self, data: &SVector<f64, ND>) -> Result<SVector<f64, NP>, FirstRowsError> {
        Q::LAYOUT.first_rows(data.as_slice()).ok_or(FirstRowsError::Sizes { tracked: NP, data: ND })
    }
}

/// A start the caller gives (a perturbed truth, a random draw made outside a timing), for any
/// data: as the given start of [`super::InstanceSolver::run_pipeline`], in the frame the
/// pipeline solves in (the problem's canonical frame, where it has one).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GivenStart<const NX: usize>(pub SVector<f64, NX>);

impl<D: ?Sized, const NX: usize> StartProvider<D, NX> for GivenStart<NX> {
    fn name(&self) -> &'static str {
        "given"
    }
    fn start(&self, _: &D) -> Result<SVector<f64, NX>, StartError> {
        Ok(self.0)
    }
}

/// A random start for any layout (the paper's "Rand" rows): a uniformly random unit quaternion
/// for each quaternion unknown, a random direction for each field whose norm an equation fixes,
/// and uniform in `[-1, 1]` for every other scalar: data scaled to order 1 (the README) has its
/// unknowns of order 1. Zero, as before 2026-12-05, is a degenerate start for a free scale or
/// focal length (a 0 that multiplies every equation's data term).
pub struct RandomStart {
    layout: Layout,
    rng: RefCell<ChaCha8Rng>,
}

impl RandomStart {
    /// Random starts for `layout`, seeded.
    pub fn new(layout: Layout, seed: u64) -> Self {
        Self { layout, rng: RefCell::new(ChaCha8Rng::seed_from_u64(seed)) }
    }
}

impl<D: ?Sized, const NX: usize> StartProvider<D, NX> for RandomStart {
    fn name(&self) -> &'static str {
        "random"
    }
    fn start(&self, _: &D) -> Result<SVector<f64, NX>, StartError> {
        let mut x = SVector::<f64, NX>::zeros();
        let mut rng = self.rng.borrow_mut();
        for f in self.layout.unknowns.iter().filter(|f| f.kind == FieldKind::Quat) {
            let q = crate::metrics::random_unit_quaternion(&mut *rng);
            x.as_mut_slice()[f.offset..f.offset + 4].copy_from_slice(&q);
        }
        // Every other field uniform in [-1, 1]; one whose norm an equation fixes (`t.dot(t) - 1`)
        // is then normalized onto its sphere, a random direction.
        for f in self.layout.unknowns.iter().filter(|f| f.kind != FieldKind::Quat) {
            x.as_mut_slice()[f.offset..f.offset + f.kind.len()].iter_mut().for_each(|v| *v = rng.random_range(-1.0..1.0));
        }
        if !self.layout.normalize_unknowns(x.as_mut_slice()) {
            return Err(StartError { provider: "random", reason: "a random field of zero norm".into() });
        }
        Ok(x)
    }
}
