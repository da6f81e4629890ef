//! Built-in simhc problems: the paper's generalized absolute pose (UPnP) and generalized
//! relative pose and scale (GRPS), each with its `#[simhc_problem]` declaration, scene sampler
//! and geometric online simulator; plus the pose error metrics of the paper.

pub mod grps;
pub mod input;
pub mod lm;
pub mod start_systems;
pub mod upnp;

/// The runtime's frames and pose metrics, under the names the built-ins have always used.
pub use simhc::{frames, metrics};
