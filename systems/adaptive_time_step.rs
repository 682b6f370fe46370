//! Chooses the tick's time step (SPEC §3, [`remembrane_core::timestep`]).
//!
//! Stage: TimeStep. Reads: [`Membrane`] (edges), [`DensePositions`], the
//! total force in [`ForceBuffers`], [`DynamicsParams`] (mobility, dt_max,
//! s_max), the V_in segmentation and the tick's edge samples (in
//! [`TermInputs`]) when a Vin plugin inserted them, and the
//! bending rigidity when a bending term did (for the explicit bending
//! step's stability bound in scenes without V_in or in the fluid model),
//! the [`remembrane_core::params::MembraneModel`] when inserted. Writes:
//! [`TimeStepChoice`]. Units: s.

use remembrane_core::energy::bending::BendingRigidity;
use remembrane_core::energy::vin::{VinEdgeSamples, VinSegmentation};
use remembrane_core::engine::force::ForceBuffers;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, DensePositions, SimError};
use remembrane_core::engine::term_inputs::TermInputs;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::DynamicsParams;
use remembrane_core::timestep::{Limiter, TimeStepChoice, bending_step_limit, choose_time_step};

/// The adaptive time-step system.
pub struct AdaptiveTimeStep;

impl System for AdaptiveTimeStep {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, ForceBuffers>,
        Res<'a, DynamicsParams>,
        Res<'a, Clock>,
        Option<Res<'a, VinSegmentation>>,
        Option<Res<'a, TermInputs>>,
        Option<Res<'a, BendingRigidity>>,
        Option<Res<'a, remembrane_core::params::MembraneModel>>,
        ResMut<'a, TimeStepChoice>,
    );

    fn name(&self) -> &str {
        "adaptive_time_step"
    }

    fn run(
        &mut self,
        (
            membrane,
            positions,
            buffers,
            d,
            clock,
            segmentation,
            samples,
            bending,
            model,
            mut time_step,
        ): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let segmentation = segmentation.filter(|_| d.vin_step_limit);
        let mut choice = choose_time_step(
            segmentation.as_deref().map(|s| &*s.0),
            &membrane.cached_topology().edges,
            samples
                .as_deref()
                .and_then(|i| i.get::<VinEdgeSamples>())
                .map_or(&[], |s| &s.0),
            &positions.0,
            &buffers.evaluation.total,
            d.mobility,
            d.dt_max,
            d.max_displacement,
        );
        // V_in's edge rule bounds the step where V_in acts on the shape; in
        // the fluid model (V_in tangential) the normal dynamics is
        // bending-limited, so the bending bound applies as without V_in.
        let fluid = model.is_some_and(|m| m.is_fluid());
        if let Some(kappa) =
            bending.filter(|_| d.bending_step_limit && (segmentation.is_none() || fluid))
        {
            let (dt, edge) = bending_step_limit(
                &membrane.cached_topology().edges,
                &positions.0,
                d.mobility,
                kappa.0,
            );
            if dt < choice.dt {
                choice = TimeStepChoice {
                    dt,
                    limiter: Limiter::Bending(edge),
                };
            }
        }
        if !(choice.dt.is_finite() && choice.dt > 0.0) {
            let element = match choice.limiter {
                Limiter::Edge(e) | Limiter::Bending(e) => format!("edge {e}"),
                Limiter::Displacement(v) => format!("vertex {v}"),
                Limiter::Cap => "the cap".to_string(),
            };
            return Err(SimError::BlowUp {
                iteration: clock.iteration + 1,
                quantity: "time step",
                term: "adaptive_time_step".into(),
                element,
                value: format!("{}", choice.dt),
            });
        }
        *time_step = choice;
        Ok(())
    }
}
