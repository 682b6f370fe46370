//! Sums the force terms, smooths the penalty forces, checks finiteness and
//! writes the total force back to the world.
//!
//! Stage: Forces (last). Reads: per-term force accumulators. Writes: total
//! force (dense and the world's `Force` components). Fails with a blow-up
//! error naming the term and vertex of the first non-finite force.

use crate::schedule::{Access, Data, System};
use crate::simulation::{SimError, SimState};

/// The force-total system.
pub struct ForceTotal;

impl System for ForceTotal {
    fn name(&self) -> &str {
        "force_total"
    }

    fn access(&self) -> Access {
        Access::new(
            &[Data::ForceAccumulators, Data::Topology],
            &[Data::ForceAccumulators],
        )
    }

    fn run(&mut self, state: &mut SimState) -> Result<(), SimError> {
        let s = state;
        let names = s.forces.names();
        for (t, (buf, energy)) in s
            .evaluation
            .term_forces
            .iter()
            .zip(&s.evaluation.energies)
            .enumerate()
        {
            let bad = buf.iter().position(|f| !f.is_finite());
            if bad.is_some() || !energy.is_finite() {
                let (element, value) = match bad {
                    Some(v) => (format!("vertex {v}"), format!("{:?}", buf[v])),
                    None => ("the energy".to_string(), format!("{energy}")),
                };
                return Err(SimError::BlowUp {
                    iteration: s.clock.iteration + 1,
                    quantity: "force",
                    term: names[t].clone(),
                    element,
                    value,
                });
            }
        }
        s.forces
            .finish(s.membrane.cached_topology(), &mut s.evaluation);
        s.membrane.scatter_forces(&s.evaluation.total);
        Ok(())
    }
}
