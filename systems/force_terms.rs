//! The system that runs every registered force term (see
//! [`remembrane_core::engine::simulation::SimBuilder::add_force_term`]).

use remembrane_core::engine::core_resources::{DenseLipid, DensePositions};
use remembrane_core::engine::error::SimError;
use remembrane_core::engine::force::{
    FORCE_TERMS, FaceGeometry, ForceBuffers, ForceContext, ForceTerm,
};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::term_inputs::TermInputs;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::util::parallel::serially;
use std::time::{Duration, Instant};

/// The system evaluating every force term into its own buffer.
///
/// Terms are independent (each writes only its own buffer and energy), so
/// on a large mesh with more than one thread they run concurrently as rayon
/// tasks, each in its serial form ([`serially`]): a term's loops split only
/// when it runs alone. Their parallel forms (gathers) do more work than
/// the serial scatters, and beside another term they find no idle thread
/// to pay for it: on the 10242-vertex red blood cell (2 threads) the two
/// terms took 1.9-2.1 ms a tick in their parallel forms, side by side, and
/// take 1.4 ms in their serial ones. Results are the same bits for any
/// thread count. Each term is timed on its own and reported under its
/// name ([`System::sub_timings`]); concurrently running terms overlap in
/// wall time.
///
/// Stage: Forces (before `force_total`). Reads: the membrane (topology, the
/// terms' own components), dense positions and lipid density, face
/// geometry, the [`TermInputs`] when a plugin publishes any. Writes: the terms (they
/// live in [`ForceBuffers`], where the flip system prices flips with them),
/// their buffers and energies.
#[derive(Default)]
pub struct ForceTermsSystem {
    names: Vec<String>,
    timings: Vec<Duration>,
}

/// One term's evaluation: where its force, energy and time go.
struct Job<'a> {
    term: &'a mut Box<dyn ForceTerm>,
    force: &'a mut Vec<glam::DVec3>,
    energy: &'a mut f64,
    time: &'a mut Duration,
}

impl System for ForceTermsSystem {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, DenseLipid>,
        Res<'a, FaceGeometry>,
        Option<Res<'a, TermInputs>>,
        ResMut<'a, ForceBuffers>,
    );

    fn name(&self) -> &str {
        FORCE_TERMS
    }

    fn run(
        &mut self,
        (membrane, positions, lipid, geometry, inputs, mut buffers): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let (terms, ev) = buffers.terms_and_evaluation();
        self.timings.resize(terms.len(), Duration::ZERO);
        if self.names.len() != terms.len() {
            self.names = terms.iter().map(|t| t.name().to_string()).collect();
        }
        let ctx = ForceContext {
            world: &membrane.world,
            topology: membrane.cached_topology(),
            positions: &positions.0,
            lipid: &lipid.0,
            face_geometry: &geometry.0,
            inputs: inputs.as_deref().unwrap_or(TermInputs::none()),
        };
        // Term work scales with the faces.
        let faces = membrane.cached_topology().faces.len();
        let concurrent = terms.len() > 1 && remembrane_core::util::parallel::splits(faces);
        // One job per term: the term, its buffer, energy and time.
        let jobs: Vec<Job<'_>> = terms
            .iter_mut()
            .zip(ev.term_forces.iter_mut())
            .zip(ev.energies.iter_mut().zip(self.timings.iter_mut()))
            .map(|((term, force), (energy, time))| Job {
                term,
                force,
                energy,
                time,
            })
            .collect();
        let evaluate = |job: Job<'_>| {
            let start = Instant::now();
            *job.energy = job.term.accumulate(&ctx, job.force);
            *job.time += start.elapsed();
        };
        if concurrent {
            rayon::scope(|s| {
                for job in jobs {
                    s.spawn(move |_| serially(|| evaluate(job)));
                }
            });
        } else {
            jobs.into_iter().for_each(evaluate);
        }
        Ok(())
    }

    fn sub_timings(&self) -> Vec<(String, Duration)> {
        self.names
            .iter()
            .zip(&self.timings)
            .map(|(n, d)| (n.clone(), *d))
            .collect()
    }
}
