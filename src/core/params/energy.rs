//! Parameters of the built-in energy terms. Each is defined in its term's
//! file under `src/energy/`, beside the kernel and the force term that use
//! it, and re-exported here.

pub use crate::energy::area::AreaParams;
pub use crate::energy::bending::{BendingDiscretisation, BendingParams};
pub use crate::energy::local_tension::LocalTensionParams;
pub use crate::energy::self_avoidance::SelfAvoidanceParams;
pub use crate::energy::springs::{SpringCoupling, SpringParams};
pub use crate::energy::tension::TensionParams;
pub use crate::energy::volume::VolumeParams;
