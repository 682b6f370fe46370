//! Resolution as a scene parameter (SPEC §8): a target edge length h.
//!
//! A scene's mesh-scale lengths are written for edges of 1 (the paper's
//! l̄); with `resolution: EdgeLength(h)` (or `FromMesh`, h the initial
//! mesh's mean edge length) every one of them is multiplied by h before the
//! simulation is built, and the quantities that depend on them follow:
//!
//! | quantity | scaling |
//! |---|---|
//! | V_in: l_min, barriers, l_max, sampling step dl | × h (steepnesses ÷ h: the same curve in l/h, the same segments) |
//! | remesh: triggers l_∓, goals l_++ and L_−, normal range | × h |
//! | remesh: kick scale D (a force, V₀/h) | ÷ h |
//! | edge flips' edge range, self-avoidance distance, Gaussian spring patch radius | × h |
//! | mobility per vertex (per-area mobility fixed: a vertex's area ∝ h²) | ÷ h² |
//! | largest displacement per step, minimiser step cap, projection's largest correction | × h (the correction: not with the Sobolev metric) |
//! | minimiser force tolerance (a vertex's force ∝ its area) | × h² |
//! | minimiser's first time step dt_start | × h |
//! | projection smoothing passes (its reach √passes·h must follow the shape) | ÷ h², rounded |
//! | diffusion sweeps per remeshing tick (rate per sweep ∝ h⁻² for the same D) | ÷ h², rounded |
//!
//! Energies (V₀, barrier heights, κ, σ, penalty constants), physical
//! positions (control points, probes, the mesh generators' sizes) and times
//! do not change, nor does FIRE's largest time step: scaled by h it slowed
//! the h = 1/2 RBC from 5309 iterations to no convergence in 20 000
//! (benches/RESULTS.md, commit faad1a5 (2026-12-03)). With h = 1 nothing changes: every existing scene builds
//! exactly as before.
//!
//! With `preconditioner: Sobolev(...)` the projection's largest correction
//! keeps its length: the projection then moves along the metric's smooth
//! constraint directions (its normal part an H² operator), so a correction
//! moves the shape, not single vertices, and a cap that shrinks with h
//! makes a deflation take ∝ 1/h iterations. Measured (2026-12-06), the
//! fluid red blood cell deflated from its spheroid directly: 475, 774, 1453
//! iterations at 642, 2562, 10242 vertices with the cap × h; 475, 371, 450
//! and 1411 at 40962 without, to the same E_b, and the refinement ladder's
//! rungs unchanged. The step cap stays × h: kept at its length too, the
//! ladder's rungs at 10242 and 40962 took 537 and 1593 iterations instead
//! of 285 and 848.

use crate::scene::Scene;
use serde::{Deserialize, Serialize};

/// The scene's resolution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Resolution {
    /// Target edge length h (l̄; default 1: the paper's mesh scale).
    EdgeLength(#[serde(deserialize_with = "crate::util::validate::positive")] f64),
    /// h is the initial mesh's mean edge length (a generator's size and
    /// level, or an imported mesh, set it).
    FromMesh,
    /// h = 1/2^refinements, reached from coarse to fine (as in the Surface
    /// Evolver): the scene runs at h = 1 on its own mesh, then every
    /// triangle of that run's final state is split into four at its edges'
    /// midpoints and the scene runs again at h = 1/2 from there, and so on.
    /// `remembrane run` runs the rungs as a protocol
    /// ([`crate::workflow::protocol::Protocol::ladder`]): `DIR/h1/`,
    /// `DIR/h1_2/`, ... and `DIR/protocol.json`.
    Ladder {
        /// Rungs after the first (1 to 4; 4 is 256 times the faces).
        refinements: u32,
    },
}

/// The most rungs a ladder may add (each quadruples the faces).
pub const MAX_LADDER_REFINEMENTS: u32 = 4;

impl Default for Resolution {
    fn default() -> Self {
        Resolution::EdgeLength(1.0)
    }
}

impl Resolution {
    /// h (l̄) for an initial mesh whose mean edge length is
    /// `mean_edge_length`; for a ladder, its finest rung's.
    pub fn edge_length(&self, mean_edge_length: f64) -> f64 {
        match *self {
            Resolution::EdgeLength(h) => h,
            Resolution::FromMesh => mean_edge_length,
            Resolution::Ladder { refinements } => ladder_edge_length(refinements),
        }
    }
}

/// A scene whose resolution is a ladder was given where it runs once
/// ([`Scene::refuse_ladder`]); the reason, without the field.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("field `resolution`: {0}")]
pub struct LadderRefused(pub String);

/// h = 1/2^rung of a ladder's rung (rung 0 is the scene's own mesh).
pub fn ladder_edge_length(rung: u32) -> f64 {
    0.5f64.powi(rung as i32)
}

/// `n` divided by h², rounded, at least 1 (for counts that scale so).
fn count_over_h2(n: u32, h: f64) -> u32 {
    ((n as f64 / (h * h)).round() as u32).max(1)
}

impl Scene {
    /// `Err` with the reason when this scene's resolution is a ladder: a
    /// sequence of runs, one per rung, which `remembrane run` runs, where
    /// `what` (a protocol's phase, a sweep's job, ...) runs the scene once.
    /// The reason names the field.
    pub fn refuse_ladder(&self, what: &str) -> Result<(), LadderRefused> {
        self.ladder_reason(what)
            .map_or(Ok(()), |r| Err(LadderRefused(r)))
    }

    /// Why `what` cannot run this scene (a ladder), without the field.
    pub(crate) fn ladder_reason(&self, what: &str) -> Option<String> {
        match self.resolution {
            Resolution::Ladder { refinements } => Some(format!(
                "Ladder(refinements: {refinements}) is a sequence of runs, one per rung, which \
                 `remembrane run` runs as a protocol; {what} runs the scene once: give \
                 EdgeLength(h)"
            )),
            _ => None,
        }
    }

    /// This scene with every mesh-scale parameter at edge length `h` (see
    /// the module table). `h = 1` returns an equal scene.
    pub fn at_resolution(&self, h: f64) -> Scene {
        let mut s = self.clone();
        if h == 1.0 {
            return s;
        }
        for term in &mut s.energy {
            term.at_resolution(h);
        }
        let r = &mut s.remesh;
        r.shorter_than *= h;
        r.longer_than *= h;
        r.split_done *= h;
        r.merge_done *= h;
        r.normal_range = (r.normal_range.0 * h, r.normal_range.1 * h);
        r.kick_scale /= h;
        if let Some(f) = &mut s.edge_flips {
            f.edge_range = (f.edge_range.0 * h, f.edge_range.1 * h);
        }
        let d = &mut s.dynamics;
        d.mobility /= h * h;
        d.max_displacement *= h;
        let metric_directions = matches!(
            d.method,
            crate::params::Method::Minimise(crate::params::MinimiserParams {
                preconditioner: crate::params::Preconditioner::Sobolev(_),
                ..
            })
        );
        if let crate::params::Method::Minimise(m) = &mut d.method {
            m.max_step *= h;
            m.force_tolerance *= h * h;
            m.dt_start *= h;
            if let crate::params::Preconditioner::Sobolev(p) = &mut m.preconditioner {
                p.tangential_scale /= h * h;
            }
        }
        if let Some(c) = &mut s.constraints {
            if !metric_directions {
                c.max_correction *= h;
            }
            c.smoothing = count_over_h2(c.smoothing, h);
        }
        if let Some(diffusion) = &mut s.diffusion {
            diffusion.sweeps = count_over_h2(diffusion.sweeps, h);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::vin::{Segmentation, VinParams};

    #[test]
    fn vin_at_half_resolution_is_the_same_curve_in_l_over_h() {
        let scene = Scene::from_ron_str(
            "Scene(membrane: Icosphere(level: 1), energy: [Vin(form: Exact)])",
            std::path::Path::new("s.ron"),
        )
        .unwrap();
        let crate::scene::EnergyTerm::Vin(p) = scene.at_resolution(0.5).energy[0] else {
            panic!()
        };
        let (half, unit) = (
            Segmentation::new(p),
            Segmentation::new(VinParams::default()),
        );
        assert_eq!(half.segment_count(), unit.segment_count());
        for l in [0.6, 0.8, 1.0, 1.13, 1.4, 1.9] {
            let (a, b) = (half.exact_and_slope(0.5 * l), unit.exact_and_slope(l));
            assert!((a.0 - b.0).abs() < 1e-9 * (1.0 + b.0.abs()), "V at {l}");
            assert!(
                (a.1 - 2.0 * b.1).abs() < 1e-9 * (1.0 + b.1.abs()),
                "V' at {l}"
            );
        }
    }

    /// The projection's correction cap follows h under plain FIRE and keeps
    /// its length under the Sobolev metric; the step cap follows h in both.
    #[test]
    fn the_metric_keeps_the_correction_cap_and_scales_the_step_cap() {
        for (metric, correction) in [("None", 0.01), ("Sobolev()", 0.02)] {
            let scene = Scene::from_ron_str(
                &format!(
                    "Scene(membrane: Icosphere(level: 1), energy: [Bending()], \
                     constraints: (area: OfInitial(1.0), max_correction: 0.02), \
                     dynamics: (method: Minimise(max_step: 0.04, preconditioner: {metric})))"
                ),
                std::path::Path::new("s.ron"),
            )
            .unwrap()
            .at_resolution(0.5);
            assert_eq!(
                scene.constraints.unwrap().max_correction,
                correction,
                "{metric}"
            );
            let crate::params::Method::Minimise(m) = scene.dynamics.method else {
                panic!()
            };
            assert_eq!(m.max_step, 0.02, "{metric}");
        }
    }

    #[test]
    fn unit_resolution_changes_nothing() {
        let scene = Scene::load(std::path::Path::new("scenes/red_blood_cell.ron")).unwrap();
        assert_eq!(scene.at_resolution(1.0), scene);
    }
}
