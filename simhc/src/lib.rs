//! simhc runtime: the traits that `#[simhc_problem]` implements, the online simulator
//! interface and the homotopy continuation tracker that runs on generated code.
//!
//! The pieces, one concern per module:
//! - [`scalar`]: the number types generated code is generic over ([`Ring`]: `f64`,
//!   `Complex<f64>`, [`interval::Interval`]; [`Scalar`] for the tracker);
//! - [`interval`], [`certify`]: outward-rounded intervals and the Krawczyk certificate of a root;
//! - [`lanes`]: several rows evaluated at once (the SIMD form of generated row kernels);
//! - [`problem`]: the traits of a compiled polynomial system `F(x; p)`;
//! - [`simulator`]: online simulators, including the generic minimum-norm one;
//! - [`tracker`], [`homotopy`], [`all_roots`], [`monodromy`]: path tracking, one path or all;
//! - [`pipeline`], [`regressor`]: the learned start and the attempts of a solve;
//! - [`solver`]: a declared problem's trait and its library solver and robust estimator
//!   ([`ransac`]), over [`start_system`] files, [`input`] readers, [`frames`] and [`metrics`];
//! - [`training`]: the learned start's training settings (the trainer is `simhc-regressor`).

pub mod all_roots;
pub mod certify;
pub mod frames;
pub mod homotopy;
pub mod input;
pub mod interval;
pub mod lanes;
pub mod layout;
pub mod metrics;
pub mod monodromy;
pub mod pipeline;
pub mod problem;
pub mod ransac;
pub mod regressor;
pub mod scalar;
pub mod simulator;
pub mod solver;
pub mod start_system;
pub mod tracker;
pub mod training;

pub use layout::{FieldKind, FieldLayout, FieldNorm, Layout, ProblemLayout};
pub use problem::{
    CoefficientForm, InstanceSizes, NoLanes, ParamDerivative, ParamLanes, ParamRowLayout, PathLanes, Problem, ProblemInfo, RowLanes,
    RowLayout,
};
pub use scalar::{Ring, Scalar};
pub use simhc_macros::{declared_problem, simhc_problem};
pub use simulator::{onto_parameter_free, MinNormSimulator, OnlineSimulator, SimulatorError};

/// Re-exports used by generated code, so user crates need no direct dependency on them.
#[doc(hidden)]
pub mod __private {
    pub use nalgebra;
}
