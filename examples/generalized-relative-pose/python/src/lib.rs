//! The example problem from Python: `import grp`, made by the one line a user's crate writes
//! for its own declared problem (`grp.solve`, `grp.estimate`, `grp.solve_batch`, `grp.solver`,
//! `grp.InputError`, `grp.SolveError`).

simhc_pymodule::python_module!(grp, generalized_relative_pose::GenRelPose::new());
