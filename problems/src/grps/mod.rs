//! Generalized relative pose and scale (GRPS): declaration, scene sampler, geometric simulator.
pub mod declared;
pub mod features;
pub mod geometry;
pub mod learned;
pub mod pose;
pub mod refine;
pub mod scene;
pub mod simulator;
mod system;
pub mod validation;

pub use system::grps::*;

use nalgebra::{Matrix3, SVector, Vector3};
use scene::GrpsCorrespondence;

impl From<&GrpsCorrespondence> for Row {
    fn from(c: &GrpsCorrespondence) -> Self {
        Row { f: c.f.into(), v: c.v.into(), fp: c.fp.into(), vp: c.vp.into() }
    }
}

/// Numbers of one correspondence in a GRPS parameter vector: `[f, v, fp, vp]`, as declared.
pub const ROW_LEN: usize = 12;

/// The correspondence of one row of a GRPS parameter vector (`ROW_LEN` numbers in the declared
/// order `[f, v, fp, vp]`; the inverse of `Row::from`).
pub fn correspondence_of_row(row: &[f64]) -> GrpsCorrespondence {
    let v3 = |k: usize| Vector3::new(row[3 * k], row[3 * k + 1], row[3 * k + 2]);
    GrpsCorrespondence { f: v3(0), v: v3(1), fp: v3(2), vp: v3(3) }
}

/// The numbers of `corrs` as parameter rows (`ROW_LEN` each, the declared order
/// `[f, v, fp, vp]`; the inverse of [`correspondence_of_row`]).
pub fn row_numbers(corrs: &[GrpsCorrespondence]) -> impl Iterator<Item = f64> + '_ {
    corrs.iter().flat_map(|c| c.f.iter().chain(&c.v).chain(&c.fp).chain(&c.vp).copied())
}

/// The first `N` correspondences of a GRPS parameter vector (`N * ROW_LEN` numbers at least).
pub fn correspondences_of<const N: usize>(p: &[f64]) -> [GrpsCorrespondence; N] {
    std::array::from_fn(|i| correspondence_of_row(&p[i * ROW_LEN..(i + 1) * ROW_LEN]))
}

/// Packs `N` correspondences as the rows of a GRPS parameter vector (`N x 12` scalars), or
/// `None` when the slice does not hold exactly `N`.
pub fn rows_of<const N: usize>(corrs: &[GrpsCorrespondence]) -> Option<[Row; N]> {
    if corrs.len() != N {
        return None;
    }
    let mut rows = [Row::default(); N];
    for (row, c) in rows.iter_mut().zip(corrs) {
        *row = Row::from(c);
    }
    Some(rows)
}

/// The 8 of `corrs` that the solvers' systems are built from when there are more
/// ([`declared::GrpsSolvers`]), spread over the camera pairs (rows
/// with the same ray origins `v` and `vp`): the first row of every pair in order of appearance,
/// then the second of every pair, and so on; the first 8 of that order, ascending. Why: rows of
/// one camera pair fix only that pair's relative pose up to scale, so 8 rows from few pairs
/// (data sorted by camera) leave the pose undetermined although all the rows fix it. `None`
/// for fewer than 8.
pub fn eight_rows(corrs: &[GrpsCorrespondence]) -> Option<[usize; 8]> {
    if corrs.len() < 8 {
        return None;
    }
    let differs = |a: Vector3<f64>, b: Vector3<f64>| (a - b).norm() > 1e-12 * (1.0 + a.norm().max(b.norm()));
    let same_pair = |a: &GrpsCorrespondence, b: &GrpsCorrespondence| !differs(a.v, b.v) && !differs(a.vp, b.vp);
    // The first row of each pair seen so far, and each row's rank within its pair.
    let mut firsts: Vec<usize> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    let mut rank = Vec::with_capacity(corrs.len());
    for (i, c) in corrs.iter().enumerate() {
        let pair = firsts.iter().position(|&f| same_pair(&corrs[f], c)).unwrap_or_else(|| {
            firsts.push(i);
            counts.push(0);
            firsts.len() - 1
        });
        rank.push(counts[pair]);
        counts[pair] += 1;
    }
    let mut order: Vec<usize> = (0..corrs.len()).collect();
    order.sort_by_key(|&i| (rank[i], i));
    let mut rows: [usize; 8] = std::array::from_fn(|k| order[k]);
    rows.sort_unstable();
    Some(rows)
}

/// `corrs` with the rows of [`eight_rows`] first (in their order), then the others (in theirs):
/// the order in which a solver builds its system from the first 8; `corrs` itself for 8 or
/// fewer.
pub fn spread_first(corrs: &[GrpsCorrespondence]) -> std::borrow::Cow<'_, [GrpsCorrespondence]> {
    let Some(rows) = eight_rows(corrs).filter(|_| corrs.len() > 8) else { return std::borrow::Cow::Borrowed(corrs) };
    let rest = (0..corrs.len()).filter(|i| !rows.contains(i));
    std::borrow::Cow::Owned(rows.into_iter().chain(rest).map(|i| corrs[i]).collect())
}

/// The solver's unknown vector `[q, t, s]` of a pose (quaternion with `q0 >= 0`).
pub fn unknowns_of(rotation: &Matrix3<f64>, translation: &Vector3<f64>, scale: f64) -> SVector<f64, 8> {
    let q = crate::metrics::quat_from_rotation(rotation);
    SVector::<f64, 8>::from([q[0], q[1], q[2], q[3], translation.x, translation.y, translation.z, scale])
}
