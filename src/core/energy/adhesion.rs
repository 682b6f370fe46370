//! Adhesion: a substrate (a plane, a bead seen from outside, or the inside
//! of a sphere or cylinder) that binds the membrane's area within a short
//! range, with adhesion energy −W per contact area.
//!
//! With d_f the distance of face f's centroid from the substrate (measured
//! into the membrane's side, the shapes of [`WallShape`]), A_f its area, W
//! the adhesion energy per area and ρ the range:
//!
//! E = −W Σ_f A_f φ(d_f), φ(d) = 1 for d ≤ 0, (1 − s)²(1 + 2s) with
//! s = d/ρ for 0 < d < ρ, and 0 beyond,
//!
//! so a face lying on the substrate gains −W A_f and the contact potential
//! fades smoothly (φ′ = 0 at both ends) over ρ. The force is −∇E: the
//! gradient of each face's area (it spreads the membrane over the
//! substrate) and of φ through its centroid (it pulls the face in). The
//! substrate is not impenetrable by itself: pair it with a [`Wall`] of the
//! same shape and a range below ρ (`scenes/open/adhesion.ron`).
//!
//! The term's recorder writes, per frame, `<name>_contact_area`
//! (Σ_f A_f φ(d_f), l̄²) and the point data `<name>_distance`; a scene's
//! recorders add `<name>_contact_curvature`, the free membrane's curvature
//! where it leaves the substrate (the main crate's
//! `analysis::contact_curvature`).
//!
//! Stage: Forces. Reads: positions, faces. Writes: force accumulator.
//! Units: W in Ē/l̄², ρ in l̄.
//!
//! [`Wall`]: super::wall

use crate::energy::wall::WallShape;
use crate::engine::force::{ForceContext, ForceTerm};
use crate::engine::recorder::{FrameData, Recorder};
use crate::engine::resources::Res;
use crate::engine::simulation::{DensePositions, Plugin, SimBuilder, SimError};
use crate::mesh::membrane::Membrane;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// An adhesive substrate: `Adhesion(shape: Plane(point: (0, 0, -5),
/// normal: (0, 0, 1)), strength: 0.5, range: 0.5)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdhesionParams {
    /// The substrate's surface (the membrane on the side a wall of that
    /// shape would keep it).
    #[serde(deserialize_with = "crate::util::validate::checked")]
    pub shape: WallShape,
    /// W, the adhesion energy per contact area (Ē/l̄² = 10 k_BT/µm²).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub strength: f64,
    /// ρ, the range over which the contact potential fades (l̄; default
    /// 0.5).
    #[serde(
        default = "default_range",
        deserialize_with = "crate::util::validate::positive"
    )]
    pub range: f64,
    /// The term's name, which its energy, timing and series columns carry
    /// (default `adhesion`). Letters, digits and `_`.
    #[serde(
        default = "default_name",
        deserialize_with = "crate::util::validate::name"
    )]
    pub name: String,
}

fn default_range() -> f64 {
    0.5
}

fn default_name() -> String {
    "adhesion".into()
}

/// φ(d) and φ′(d) of the contact potential with range `range`.
fn contact(d: f64, range: f64) -> (f64, f64) {
    if d <= 0.0 {
        return (1.0, 0.0);
    }
    if d >= range {
        return (0.0, 0.0);
    }
    let s = d / range;
    let one_minus = 1.0 - s;
    (
        one_minus * one_minus * (1.0 + 2.0 * s),
        -6.0 * s * one_minus / range,
    )
}

/// φ″(d) of the contact potential with range `range` (0 outside (0, ρ)).
fn contact_curvature(d: f64, range: f64) -> f64 {
    if d <= 0.0 || d >= range {
        return 0.0;
    }
    (12.0 * d / range - 6.0) / (range * range)
}

/// The adhesion energy (Ē) of the faces at `positions`; with `force`, adds
/// −∇E. Also returns the contact area Σ_f A_f φ(d_f) (l̄²).
pub fn adhesion_energy(
    params: &AdhesionParams,
    faces: &[[u32; 3]],
    positions: &[DVec3],
    mut force: Option<&mut [DVec3]>,
) -> (f64, f64) {
    let mut contact_area = 0.0;
    for f in faces {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let centroid = (a + b + c) / 3.0;
        let (d, gradient) = params.shape.distance(centroid);
        let (phi, dphi) = contact(d, params.range);
        if phi == 0.0 && dphi == 0.0 {
            continue;
        }
        let n = (b - a).cross(c - a);
        let twice_area = n.length();
        let area = 0.5 * twice_area;
        contact_area += area * phi;
        if let Some(force) = force.as_deref_mut() {
            // −∂E/∂x_k = W [φ ∂A/∂x_k + A φ′ ∇d / 3], ∂A/∂a = ½ n̂ × (c − b)
            // and cyclically.
            let n_hat = n / twice_area;
            let w = params.strength;
            let pull = gradient * (w * area * dphi / 3.0);
            let spread = 0.5 * w * phi;
            force[f[0] as usize] += n_hat.cross(c - b) * spread + pull;
            force[f[1] as usize] += n_hat.cross(a - c) * spread + pull;
            force[f[2] as usize] += n_hat.cross(b - a) * spread + pull;
        }
    }
    (-params.strength * contact_area, contact_area)
}

/// The adhesion force term.
pub struct AdhesionForces {
    params: AdhesionParams,
}

impl AdhesionForces {
    /// The substrate `params` declare.
    pub fn new(params: AdhesionParams) -> Self {
        Self { params }
    }
}

impl ForceTerm for AdhesionForces {
    fn name(&self) -> &str {
        &self.params.name
    }

    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        adhesion_energy(&self.params, &ctx.topology.faces, ctx.positions, force).0
    }

    /// W A_f |φ″(d_f)| per face within the range, a third to each of its
    /// vertices: the contact potential is as stiff as W·6/ρ² per area, far
    /// beyond bending at the ladder's fine rungs (ρ shrinks with h).
    fn normal_stiffness(&self, ctx: &ForceContext<'_>, out: &mut [f64]) -> bool {
        let p = &self.params;
        for f in &ctx.topology.faces {
            let [a, b, c] = f.map(|i| ctx.positions[i as usize]);
            let (d, _) = p.shape.distance((a + b + c) / 3.0);
            let curvature = contact_curvature(d, p.range);
            if curvature == 0.0 {
                continue;
            }
            let area = 0.5 * (b - a).cross(c - a).length();
            let share = p.strength * area * curvature.abs() / 3.0;
            for &v in f {
                out[v as usize] += share;
            }
        }
        true
    }
}

/// The substrate's series column and point data (see the module header).
pub struct AdhesionRecorder {
    params: AdhesionParams,
}

impl Recorder for AdhesionRecorder {
    type Data<'a> = (Res<'a, Membrane>, Res<'a, DensePositions>);

    fn name(&self) -> &str {
        &self.params.name
    }

    fn record(
        &mut self,
        (membrane, positions): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        let p = &self.params;
        let faces = &membrane.cached_topology().faces;
        let (_, contact_area) = adhesion_energy(p, faces, &positions.0, None);
        let distances = positions.0.iter().map(|&x| p.shape.distance(x).0);
        frame.column(format!("{}_contact_area", p.name), contact_area);
        frame.scalars(format!("{}_distance", p.name), distances.collect());
        Ok(())
    }
}

/// An adhesive substrate: its force term and its recorder.
pub fn plugin(params: AdhesionParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.add_force_term(AdhesionForces::new(params.clone()))?;
        b.add_recorder(AdhesionRecorder { params });
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for AdhesionParams {
    /// Correct on open meshes: a sum over faces of their area times a contact weight: nothing in it assumes a closed surface.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(self.clone())
    }

    /// The range ρ is written for h = 1 and scales with the mesh (× h), so
    /// a refinement ladder also takes ρ → 0, the limit in which the contact
    /// curvature is √(2W/κ); the substrate is a physical position and stays
    /// where the scene puts it.
    fn at_resolution(&mut self, h: f64) {
        self.range *= h;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fd::{FdOptions, check_force_term, perturbed_icosphere};

    fn substrates() -> Vec<AdhesionParams> {
        let params = |shape| AdhesionParams {
            shape,
            strength: 0.7,
            range: 1.2,
            name: "adhesion".into(),
        };
        // The perturbed level-3 icosphere has radius ≈ 6.65 l̄: each
        // substrate cuts into it, so faces lie on all three parts of φ.
        vec![
            params(WallShape::Plane {
                point: (0.0, 0.0, -6.0),
                normal: (0.1, -0.2, 1.0),
            }),
            params(WallShape::SphereOutside {
                center: (0.3, 0.2, 9.0),
                radius: 2.8,
            }),
            params(WallShape::SphereInside {
                center: (0.2, -0.1, 0.3),
                radius: 6.5,
            }),
        ]
    }

    #[test]
    fn force_matches_finite_differences_for_every_shape() {
        let mesh = perturbed_icosphere(3, 83);
        let mut membrane = Membrane::from_mesh(&mesh, false).unwrap();
        membrane.topology().unwrap();
        let mut positions = Vec::new();
        membrane.gather_positions(&mut positions);
        let faces = &membrane.cached_topology().faces;
        for params in substrates() {
            let (energy, contact_area) = adhesion_energy(&params, faces, &positions, None);
            let (inside, fading) = faces.iter().fold((0, 0), |(i, f), face| {
                let c = face.map(|k| positions[k as usize]);
                let d = params.shape.distance((c[0] + c[1] + c[2]) / 3.0).0;
                (
                    i + (d <= 0.0) as usize,
                    f + (d > 0.0 && d < params.range) as usize,
                )
            });
            assert!(
                inside > 5 && fading > 20,
                "{:?}: {inside} {fading}",
                params.shape
            );
            assert!((energy + params.strength * contact_area).abs() < 1e-12);
            let step = FdOptions::default().step;
            let mut term = AdhesionForces::new(params.clone());
            let report = check_force_term(
                &mut term,
                &membrane.world,
                membrane.cached_topology(),
                &positions,
                &[],
                None,
                FdOptions {
                    abs_floor: 64.0 * f64::EPSILON * energy.abs() / step,
                    ..FdOptions::default()
                },
            );
            assert!(
                report.passed(),
                "{:?}: {} failures, max rel. error {:.2e}",
                params.shape,
                report.failures.len(),
                report.max_rel_error
            );
        }
    }

    /// Translating the membrane by t along a plane substrate's normal
    /// keeps every face's area and moves its distance by t, so d²E/dt² is
    /// −W Σ_f A_f φ″(d_f). With a range long enough that every face within
    /// it lies on φ's concave half (φ″ < 0), that is the sum of the
    /// vertices' stiffnesses.
    #[test]
    fn normal_stiffness_is_the_second_derivative_along_a_plane_substrate() {
        let mesh = perturbed_icosphere(3, 83);
        let mut membrane = Membrane::from_mesh(&mesh, false).unwrap();
        membrane.topology().unwrap();
        let mut positions = Vec::new();
        membrane.gather_positions(&mut positions);
        // The plane below the whole membrane (φ is only C¹ at d = 0).
        let params = AdhesionParams {
            shape: WallShape::Plane {
                point: (0.0, 0.0, -8.0),
                normal: (0.1, -0.2, 1.0),
            },
            range: 30.0,
            ..substrates().swap_remove(0)
        };
        let (_, normal) = params.shape.distance(DVec3::ZERO);
        let faces = &membrane.cached_topology().faces;
        let (sum, fd) = crate::fd::normal_stiffness_against_translation(
            &mut AdhesionForces::new(params.clone()),
            &membrane.world,
            membrane.cached_topology(),
            &positions,
            normal,
            1e-3,
        );
        assert!(faces.iter().all(|f| {
            let c = f.map(|k| positions[k as usize]);
            let d = params.shape.distance((c[0] + c[1] + c[2]) / 3.0).0;
            d > 0.0 && d < 0.5 * params.range
        }));
        assert!(
            sum > 0.0 && (sum - fd).abs() < 1e-5 * fd,
            "{sum} against {fd}"
        );
    }

    #[test]
    fn a_flat_membrane_on_the_substrate_gains_w_per_area() {
        // Two triangles of area 1 each, lying on the plane z = 0.
        let positions = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
        ];
        let faces = [[0, 1, 2], [1, 3, 2]];
        let mut params = AdhesionParams {
            shape: WallShape::Plane {
                point: (0.0, 0.0, 0.0),
                normal: (0.0, 0.0, 1.0),
            },
            strength: 0.25,
            range: 0.4,
            name: "adhesion".into(),
        };
        let (e, area) = adhesion_energy(&params, &faces, &positions, None);
        assert!((area - 2.0).abs() < 1e-15 && (e + 0.5).abs() < 1e-15);
        // Lifted by half the range: φ = ½; beyond the range: nothing.
        let lift = |z: f64| positions.map(|p| p + DVec3::Z * z);
        let (_, half) = adhesion_energy(&params, &faces, &lift(0.2), None);
        assert!((half - 1.0).abs() < 1e-14);
        assert_eq!(
            adhesion_energy(&params, &faces, &lift(0.4), None),
            (-0.0, 0.0)
        );
        crate::energy::builtin::BuiltinTerm::at_resolution(&mut params, 2.0);
        assert!((params.range - 0.8).abs() < 1e-15);
    }
}
