//! Walls: a rigid surface the membrane cannot pass (a plane, a sphere from
//! outside or inside, or the inside of a cylinder), felt by every vertex
//! through a short-range repulsion. The surfaces ([`WallShape`]) also serve
//! the adhesive substrates ([`super::adhesion`]).
//!
//! With d_i the distance of vertex i from the wall, measured into the
//! allowed region, ε the strength and r the range:
//!
//! E = Σ_{i: d_i < r} ε (r/d_i − 1)³,
//! F_i = 3ε (r/d_i − 1)² (r/d_i²) ∇d_i (away from the wall).
//!
//! E, F and ∂F/∂d vanish at d = r (the potential is C², so the integrator
//! and finite differences see no kink), and E grows as ε r³/d³ towards the
//! wall: ε at d = r/2, 8ε at d = r/3. A vertex on or beyond the wall makes
//! the energy infinite, which the force stage reports as a blow-up naming
//! the term instead of writing the frame. The allowed regions are convex,
//! so no face can cross the wall while its vertices stay on the allowed
//! side.
//!
//! The term's recorder writes, per frame, `<name>_force` (Σ_i |F_i|, the
//! total normal force the wall exerts, Ē/l̄), `<name>_contacts` (vertices
//! within range), `<name>_min_distance` (min_i d_i, l̄), `<name>_virial`
//! (−Σ_i F_i·(x_i − c), Ē, with c the shape's point or centre: for a
//! cylinder or a sphere from inside, Σ_i |F_i| ρ_i with ρ_i the vertex's
//! distance from the axis or centre; the wall's side of the virial balance
//! in docs/open_meshes.md) and the point data `<name>_distance` (d_i).
//!
//! Stage: Forces. Reads: positions. Writes: force accumulator. Units: ε in
//! Ē, r and all lengths in l̄.

use crate::engine::error::BuildError;
use crate::engine::force::{FlipProposal, ForceContext, ForceTerm};
use crate::engine::recorder::{FrameData, Recorder};
use crate::engine::resources::Res;
use crate::engine::simulation::{DensePositions, Plugin, SimBuilder, SimError};
use crate::mesh::components::Position;
use crate::mesh::membrane::Membrane;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// The wall's surface; the membrane lives on one side of it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum WallShape {
    /// The plane through `point`; the membrane stays on the side `normal`
    /// points to.
    Plane {
        /// A point of the plane (l̄).
        point: (f64, f64, f64),
        /// Normal towards the membrane's side (any non-zero length).
        normal: (f64, f64, f64),
    },
    /// A sphere (a bead) the membrane stays outside of.
    SphereOutside {
        /// Centre (l̄).
        center: (f64, f64, f64),
        /// Radius (l̄).
        radius: f64,
    },
    /// A sphere the membrane stays inside.
    SphereInside {
        /// Centre (l̄).
        center: (f64, f64, f64),
        /// Radius (l̄).
        radius: f64,
    },
    /// An infinite cylinder the membrane stays inside.
    CylinderInside {
        /// A point of the axis (l̄).
        point: (f64, f64, f64),
        /// Axis direction (any non-zero length).
        axis: (f64, f64, f64),
        /// Radius (l̄).
        radius: f64,
    },
}

fn vec3(v: (f64, f64, f64)) -> DVec3 {
    DVec3::new(v.0, v.1, v.2)
}

impl WallShape {
    /// The distance of `x` from the wall into the allowed region (negative
    /// beyond the wall) and its gradient (a unit vector away from the wall).
    pub fn distance(&self, x: DVec3) -> (f64, DVec3) {
        match *self {
            WallShape::Plane { point, normal } => {
                let n = vec3(normal).normalize();
                ((x - vec3(point)).dot(n), n)
            }
            WallShape::SphereOutside { center, radius } => {
                let r = x - vec3(center);
                let len = r.length();
                (len - radius, r / len)
            }
            WallShape::SphereInside { center, radius } => {
                let r = x - vec3(center);
                let len = r.length();
                (radius - len, -r / len)
            }
            WallShape::CylinderInside {
                point,
                axis,
                radius,
            } => {
                let a = vec3(axis).normalize();
                let r = x - vec3(point);
                let radial = r - r.dot(a) * a;
                let len = radial.length();
                (radius - len, -radial / len)
            }
        }
    }
}

impl WallShape {
    /// The shape's reference point c (the plane's point, the sphere's
    /// centre, the cylinder's axis point), the origin of the wall's virial.
    pub fn reference_point(&self) -> DVec3 {
        match *self {
            WallShape::Plane { point, .. } | WallShape::CylinderInside { point, .. } => vec3(point),
            WallShape::SphereOutside { center, .. } | WallShape::SphereInside { center, .. } => {
                vec3(center)
            }
        }
    }
}

impl crate::util::validate::Validate for WallShape {
    fn validate(&self) -> Result<(), crate::util::validate::ValidationError> {
        let finite = |v: (f64, f64, f64)| v.0.is_finite() && v.1.is_finite() && v.2.is_finite();
        let (points, direction, radius) = match *self {
            WallShape::Plane { point, normal } => (point, Some(normal), None),
            WallShape::SphereOutside { center, radius }
            | WallShape::SphereInside { center, radius } => (center, None, Some(radius)),
            WallShape::CylinderInside {
                point,
                axis,
                radius,
            } => (point, Some(axis), Some(radius)),
        };
        if !finite(points) {
            return Err("the wall's point or centre must be finite".into());
        }
        if let Some(d) = direction
            && !(finite(d) && vec3(d).length() > 0.0)
        {
            return Err("the wall's normal or axis must be a finite, non-zero vector".into());
        }
        if let Some(r) = radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("the wall's radius must be a finite number > 0, not {r}").into());
        }
        Ok(())
    }
}

/// A wall: `Wall(shape: CylinderInside(point: (0, 0, 0), axis: (0, 0, 1),
/// radius: 4.0), strength: 1.0, range: 0.5)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallParams {
    /// The wall's surface.
    #[serde(deserialize_with = "crate::util::validate::checked")]
    pub shape: WallShape,
    /// ε, the energy of a vertex at half the range from the wall (Ē;
    /// default 1 Ē = 10 k_BT).
    #[serde(
        default = "default_strength",
        deserialize_with = "crate::util::validate::positive"
    )]
    pub strength: f64,
    /// r, the range of the repulsion (l̄; default 0.5: half an edge).
    #[serde(
        default = "default_range",
        deserialize_with = "crate::util::validate::positive"
    )]
    pub range: f64,
    /// The term's name, which its energy, timing and series columns carry
    /// (default `wall`; two walls need two names). Letters, digits and `_`.
    #[serde(
        default = "default_name",
        deserialize_with = "crate::util::validate::name"
    )]
    pub name: String,
}

fn default_strength() -> f64 {
    1.0
}

fn default_range() -> f64 {
    0.5
}

fn default_name() -> String {
    "wall".into()
}

/// One vertex's energy ε (r/d − 1)³ at distance 0 < d < r from the wall
/// and the magnitude of its push away from it, −∂E/∂d.
fn repulsion(d: f64, strength: f64, range: f64) -> (f64, f64) {
    let q = range / d - 1.0;
    (
        strength * q * q * q,
        3.0 * strength * q * q * range / (d * d),
    )
}

/// ∂²E/∂d² of one vertex's energy ε (r/d − 1)³ at 0 < d < r.
fn repulsion_stiffness(d: f64, strength: f64, range: f64) -> f64 {
    let q = range / d - 1.0;
    6.0 * strength * q * range / (d * d * d) * (range / d + q)
}

/// The wall energy (Ē) of `positions`; with `force`, adds −∇E. A vertex on
/// or beyond the wall gives +∞ (and no force).
pub fn wall_energy(
    shape: &WallShape,
    strength: f64,
    range: f64,
    positions: &[DVec3],
    mut force: Option<&mut [DVec3]>,
) -> f64 {
    let mut energy = 0.0;
    for (i, &x) in positions.iter().enumerate() {
        let (d, gradient) = shape.distance(x);
        if d >= range {
            continue;
        }
        if d <= 0.0 {
            energy = f64::INFINITY;
            continue;
        }
        let (e, push) = repulsion(d, strength, range);
        energy += e;
        if let Some(f) = force.as_deref_mut() {
            f[i] += gradient * push;
        }
    }
    energy
}

/// The wall force term.
pub struct WallForces {
    params: WallParams,
}

impl WallForces {
    /// The wall `params` declare.
    pub fn new(params: WallParams) -> Self {
        Self { params }
    }
}

impl ForceTerm for WallForces {
    fn name(&self) -> &str {
        &self.params.name
    }

    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        let p = &self.params;
        wall_energy(&p.shape, p.strength, p.range, ctx.positions, force)
    }

    /// A flip moves no vertex, and the energy is a sum over vertices.
    fn flip_energy_change(&mut self, _proposal: &FlipProposal<'_>) -> Option<f64> {
        Some(0.0)
    }

    /// ε ∂²(r/d − 1)³/∂d² at each vertex within the range.
    fn normal_stiffness(&self, ctx: &ForceContext<'_>, out: &mut [f64]) -> bool {
        let p = &self.params;
        for (o, &x) in out.iter_mut().zip(ctx.positions) {
            let (d, _) = p.shape.distance(x);
            if d > 0.0 && d < p.range {
                *o += repulsion_stiffness(d, p.strength, p.range);
            }
        }
        true
    }
}

/// The wall's series columns and point data (see the module header).
pub struct WallRecorder {
    params: WallParams,
}

impl Recorder for WallRecorder {
    type Data<'a> = Res<'a, DensePositions>;

    fn name(&self) -> &str {
        &self.params.name
    }

    fn record(&mut self, positions: Self::Data<'_>, frame: &mut FrameData) -> Result<(), SimError> {
        let p = &self.params;
        let c = p.shape.reference_point();
        let mut distances = Vec::with_capacity(positions.0.len());
        let (mut total, mut virial, mut contacts) = (0.0, 0.0, 0u64);
        for &x in positions.0.iter() {
            let (d, gradient) = p.shape.distance(x);
            distances.push(d);
            if d < p.range {
                let push = repulsion(d, p.strength, p.range).1;
                total += push;
                virial -= push * gradient.dot(x - c);
                contacts += 1;
            }
        }
        let min = distances.iter().copied().fold(f64::INFINITY, f64::min);
        frame.column(format!("{}_force", p.name), total);
        frame.count(format!("{}_contacts", p.name), contacts);
        frame.column(format!("{}_min_distance", p.name), min);
        frame.column(format!("{}_virial", p.name), virial);
        frame.scalars(format!("{}_distance", p.name), distances);
        Ok(())
    }
}

/// Refuses a wall that the initial membrane already touches or crosses: its
/// energy would be infinite before the first step.
fn check_initial_membrane(b: &SimBuilder, shape: &WallShape) -> Result<(), BuildError> {
    let Ok(membrane) = b.resources().get::<Membrane>() else {
        return Ok(());
    };
    let mut query = membrane.world.query::<&Position>();
    let distances = query.iter().map(|p| shape.distance(p.0).0);
    let (beyond, closest) = distances
        .filter(|&d| d <= 0.0)
        .fold((0usize, 0.0f64), |(n, m), d| (n + 1, m.min(d)));
    match beyond {
        0 => Ok(()),
        n => Err(BuildError::Invalid {
            field: "shape".into(),
            reason: format!(
                "{n} vertices of the initial membrane are on or beyond the wall (the farthest \
                 {:.3} l̄ beyond it); move the wall or the membrane",
                -closest
            ),
        }),
    }
}

/// A wall: its force term and its recorder.
pub fn plugin(params: WallParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        check_initial_membrane(b, &params.shape)?;
        b.add_force_term(WallForces::new(params.clone()))?;
        b.add_recorder(WallRecorder { params });
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for WallParams {
    /// Correct on open meshes: one repulsion per vertex: nothing in it assumes a closed surface.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(self.clone())
    }

    /// The range is a mesh-scale length (× h); the wall's surface is a
    /// physical position and stays where the scene puts it.
    fn at_resolution(&mut self, h: f64) {
        self.range *= h;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fd::{FdOptions, check_force_term, perturbed_icosphere};
    use crate::mesh::membrane::Membrane;

    /// Walls that cut into the perturbed level-3 icosphere (radius ≈ 6.1 l̄,
    /// mean edge 1 l̄) with a range that reaches many vertices but none
    /// beyond the wall.
    fn walls() -> Vec<WallParams> {
        let wall = |shape| WallParams {
            shape,
            strength: 2.0,
            range: 1.5,
            name: "wall".into(),
        };
        vec![
            wall(WallShape::Plane {
                point: (0.0, 0.0, -7.0),
                normal: (0.1, 0.2, 1.0),
            }),
            wall(WallShape::SphereInside {
                center: (0.3, -0.2, 0.1),
                radius: 7.4,
            }),
            wall(WallShape::CylinderInside {
                point: (0.2, 0.1, 0.0),
                axis: (0.2, -0.1, 1.0),
                radius: 7.3,
            }),
            // A bead just outside the sphere's surface.
            wall(WallShape::SphereOutside {
                center: (0.4, 0.3, 9.3),
                radius: 2.5,
            }),
        ]
    }

    #[test]
    fn force_matches_finite_differences_for_every_shape() {
        let mesh = perturbed_icosphere(3, 71);
        let mut membrane = Membrane::from_mesh(&mesh, false).unwrap();
        membrane.topology().unwrap();
        let mut positions = Vec::new();
        membrane.gather_positions(&mut positions);
        for params in walls() {
            let mut term = WallForces::new(params.clone());
            // The round-off floor of the difference quotient: a few ulps of
            // the whole energy over the step.
            let p = &params;
            let energy = wall_energy(&p.shape, p.strength, p.range, &positions, None);
            let step = FdOptions::default().step;
            let report = check_force_term(
                &mut term,
                &membrane.world,
                membrane.cached_topology(),
                &positions,
                &[],
                None,
                FdOptions {
                    abs_floor: 64.0 * f64::EPSILON * energy / step,
                    ..FdOptions::default()
                },
            );
            let touched = positions
                .iter()
                .filter(|&&x| params.shape.distance(x).0 < params.range)
                .count();
            assert!(
                touched > 20,
                "{:?}: only {touched} vertices in range",
                p.shape
            );
            assert!(
                energy.is_finite() && energy > 0.0,
                "{:?}: E = {energy}",
                p.shape
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

    /// Translating the membrane by t along a plane wall's normal moves
    /// every vertex's distance by t, so d²E/dt² is the sum of the
    /// vertices' stiffnesses exactly.
    #[test]
    fn normal_stiffness_is_the_second_derivative_along_a_plane_wall() {
        let mesh = perturbed_icosphere(3, 71);
        let mut membrane = Membrane::from_mesh(&mesh, false).unwrap();
        membrane.topology().unwrap();
        let mut positions = Vec::new();
        membrane.gather_positions(&mut positions);
        let params = walls().swap_remove(0);
        let (_, normal) = params.shape.distance(DVec3::ZERO);
        let (sum, fd) = crate::fd::normal_stiffness_against_translation(
            &mut WallForces::new(params.clone()),
            &membrane.world,
            membrane.cached_topology(),
            &positions,
            normal,
            1e-4,
        );
        assert!(
            sum > 0.0 && (sum - fd).abs() < 1e-5 * fd,
            "{sum} against {fd}"
        );
    }

    #[test]
    fn distances_are_exact_and_the_energy_is_smooth_at_the_range() {
        let cylinder = WallShape::CylinderInside {
            point: (1.0, 1.0, 0.0),
            axis: (0.0, 0.0, 3.0),
            radius: 2.0,
        };
        let (d, g) = cylinder.distance(DVec3::new(2.5, 1.0, 7.0));
        assert!((d - 0.5).abs() < 1e-15 && (g - DVec3::NEG_X).length() < 1e-15);
        let sphere = WallShape::SphereInside {
            center: (0.0, 0.0, 0.0),
            radius: 3.0,
        };
        assert!((sphere.distance(DVec3::new(0.0, 4.0, 0.0)).0 + 1.0).abs() < 1e-15);
        // ε at half the range; C² at the range; infinite beyond the wall.
        let plane = WallShape::Plane {
            point: (0.0, 0.0, 0.0),
            normal: (0.0, 0.0, 2.0),
        };
        let e = |z: f64| wall_energy(&plane, 1.5, 0.4, &[DVec3::new(0.0, 0.0, z)], None);
        assert!((e(0.2) - 1.5).abs() < 1e-12);
        let h = 1e-4;
        assert!(e(0.4 - h) < 1e-10 && e(0.4) == 0.0);
        assert_eq!(e(-0.1), f64::INFINITY);
        assert_eq!(e(0.0), f64::INFINITY);
    }

    #[test]
    fn bad_shapes_are_refused_with_a_reason() {
        use crate::util::validate::Validate;
        let flat = WallShape::Plane {
            point: (0.0, 0.0, 0.0),
            normal: (0.0, 0.0, 0.0),
        };
        assert!(
            flat.validate()
                .unwrap_err()
                .to_string()
                .contains("normal or axis")
        );
        let sphere = WallShape::SphereInside {
            center: (0.0, 0.0, 0.0),
            radius: -1.0,
        };
        assert!(
            sphere
                .validate()
                .unwrap_err()
                .to_string()
                .contains("radius")
        );
    }
}
