//! Barrier-crossing detection: the edges outside [l_−, l_+].
//!
//! Stage: BarrierCheck. Reads: positions, topology, triggers. Writes: the
//! list of abnormal edges (slots), consumed by remeshing.

use crate::schedule::{Access, Data, System};
use crate::simulation::{SimError, SimState};

/// The barrier-check system.
pub struct BarrierCheck;

impl System for BarrierCheck {
    fn name(&self) -> &str {
        "barrier_check"
    }

    fn access(&self) -> Access {
        Access::new(
            &[Data::Positions, Data::Topology],
            &[Data::BarrierCrossings],
        )
    }

    fn run(&mut self, state: &mut SimState) -> Result<(), SimError> {
        let s = state;
        let (short, long) = (s.remesh.shorter_than, s.remesh.longer_than);
        let (short2, long2) = (short * short, long * long);
        s.abnormal_edges.clear();
        let p = &s.positions;
        for (e, &[a, b]) in s.membrane.cached_topology().edges.iter().enumerate() {
            let l2 = p[a as usize].distance_squared(p[b as usize]);
            if !(short2..=long2).contains(&l2) {
                s.abnormal_edges.push(e as u32);
            }
        }
        Ok(())
    }
}
