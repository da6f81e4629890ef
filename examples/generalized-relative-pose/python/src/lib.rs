//! The example problem from Python: `import gen_relpose`, made by the one line a user's crate writes
//! for its own declared problem (`gen_relpose.solve`, `gen_relpose.estimate`, `gen_relpose.solve_batch`, `gen_relpose.solver`,
//! `gen_relpose.InputError`, `gen_relpose.SolveError`).

simhc_pymodule::python_module!(gen_relpose, generalized_relative_pose::GenRelPose::new());
