//! Built-in simhc problems: the paper's generalized absolute pose (UPnP) and generalized
//! relative pose and scale (GRPS), each with its `#[simhc_problem]` declaration, scene sampler
//! and geometric online simulator; plus the pose error metrics of the paper.

pub mod frames;
pub mod grps;
pub mod input;
pub mod lm;
pub mod metrics;
pub mod start_systems;
pub mod upnp;
