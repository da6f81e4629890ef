//! Several start hypotheses from one forward pass: a learned start trained with a
//! winner-takes-all loss predicts [`crate::pipeline::LearnedStart::hypotheses`] guesses of the unknowns and a
//! score for each; they are ranked by their scores (an unscored network's by how well each
//! explains all of the data's rows, [`super::DeclaredProblem::row_error`] squared and summed) and
//! tracked in that order before any fallback. Why rank: the network is trained so that *one*
//! of its guesses is close, not a given one; its scores are trained to say which.
//!
//! A schedule names a hypothesis by its rank, as predicted or refined on all the data
//! ([`super::StartId::Learned`]); a schedule of one hypothesis ([`super::shipped_schedule`])
//! names the first-ranked only, and [`super::schedule::ranked_schedule`] repeats it for every
//! rank.

use crate::pipeline::{StartError, StartProvider, MAX_HYPOTHESES};
use nalgebra::SVector;
use std::cell::RefCell;

/// A learned start's hypotheses on one datum, best first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranked<const NX: usize> {
    /// The hypotheses; the first `count` are set.
    pub x: [SVector<f64, NX>; MAX_HYPOTHESES],
    /// How many there are.
    pub count: usize,
}

impl<const NX: usize> Ranked<NX> {
    /// One hypothesis.
    pub fn one(x: SVector<f64, NX>) -> Self {
        let mut r = Self { x: [SVector::zeros(); MAX_HYPOTHESES], count: 1 };
        r.x[0] = x;
        r
    }
}

/// A learned start: up to [`MAX_HYPOTHESES`] guesses of the unknowns from one forward pass.
pub trait LearnedHypotheses<D: ?Sized, const NX: usize> {
    /// How many hypotheses a forward pass makes.
    fn hypotheses(&self) -> usize;
    /// The hypotheses for `data`, best first.
    fn rank(&self, data: &D) -> Result<Ranked<NX>, StartError>;
}

/// The ranked hypotheses of one solve, computed at the first request and kept for the datum
/// they were computed from: a solve asks for them on one (canonical) datum. A set serves one
/// datum: it is keyed by the datum's address, so make a new set for each datum (one at a
/// reused address, a stack slot in a loop, would get the old hypotheses).
pub struct RankedStarts<'a, L, const NX: usize> {
    learned: &'a L,
    ranked: RefCell<Option<(DatumKey, Result<Ranked<NX>, StartError>)>>,
}

impl<'a, L, const NX: usize> RankedStarts<'a, L, NX> {
    /// The hypotheses of `learned`, not yet computed.
    pub fn new(learned: &'a L) -> Self {
        Self { learned, ranked: RefCell::new(None) }
    }

    /// How many hypotheses a forward pass makes.
    pub fn count<D: ?Sized>(&self) -> usize
    where
        L: LearnedHypotheses<D, NX>,
    {
        self.learned.hypotheses()
    }

    /// The hypothesis of `rank` for `data` (an error when the network gave fewer).
    pub fn start<D: ?Sized>(&self, data: &D, rank: usize) -> Result<SVector<f64, NX>, StartError>
    where
        L: LearnedHypotheses<D, NX>,
    {
        let key: DatumKey = (data as *const D as *const u8, std::mem::size_of_val(data));
        let mut cache = self.ranked.borrow_mut();
        if !matches!(&*cache, Some((k, _)) if *k == key) {
            *cache = Some((key, self.learned.rank(data)));
        }
        let Some((_, ranked)) = &*cache else { unreachable!("just filled") };
        match ranked {
            Ok(r) if rank < r.count => Ok(r.x[rank]),
            Ok(_) => Err(StartError { provider: "learned", reason: format!("no hypothesis of rank {rank}").into() }),
            Err(e) => Err(e.clone()),
        }
    }
}

/// Where a datum is and how many bytes it spans (a slice and its prefix differ).
type DatumKey = (*const u8, usize);

/// The hypothesis of one rank, as a start provider.
pub struct RankedStart<'h, 'a, L, const NX: usize> {
    /// The solve's hypotheses.
    pub set: &'h RankedStarts<'a, L, NX>,
    /// Which one (0: the best).
    pub rank: usize,
}

impl<L, D: ?Sized, const NX: usize> StartProvider<D, NX> for RankedStart<'_, '_, L, NX>
where
    L: LearnedHypotheses<D, NX>,
{
    fn name(&self) -> &'static str {
        if self.rank == 0 {
            "learned"
        } else {
            "learned, another hypothesis"
        }
    }
    fn start(&self, data: &D) -> Result<SVector<f64, NX>, StartError> {
        self.set.start(data, self.rank)
    }
}
