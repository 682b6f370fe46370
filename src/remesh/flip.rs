//! Edge flips as Metropolis moves: the geometry of a flip and the energy
//! change it causes, computed from the few faces it touches.
//!
//! A flip replaces the edge a–b, shared by faces (a, b, c) and (b, a, d),
//! with the edge c–d: faces (a, d, c) and (d, b, c). No vertex moves, so
//! only the energies that depend on the triangulation change: V_in (one
//! edge out, one in), Helfrich bending at a, b, c and d (their rings'
//! cotangents and mixed areas), the enclosed volume and the area (the two
//! faces' tetrahedra and areas), and with them the volume and area
//! penalties and a constant tension. Control-point springs are kept
//! unchanged by never flipping at a point's nearest vertex. Accepting a proposed flip with
//! probability min(1, exp(−ΔE/k_BT)) keeps the Boltzmann distribution of
//! the whole energy (the proposal, a uniformly drawn edge, is symmetric:
//! a closed mesh keeps its edge count under flips), so a membrane that
//! moves by Langevin dynamics and flips by this rule samples a fluid
//! membrane's ensemble (dynamically triangulated surfaces; Gompper & Kroll,
//! Phys. Rev. E 51, 514, 1995).

use crate::energy::vin::{Segmentation, VinForm};
use crate::mesh::geometry::Corners;
use crate::mesh::topology::Topology;
use glam::DVec3;
use std::sync::Arc;

/// The energy terms a flip changes, with their parameters (built from the
/// scene's energy list; a term not listed here cannot be flipped under).
#[derive(Clone, Debug, Default)]
pub struct FlipEnergy {
    /// V_in and the form the dynamics uses (none in the geometric baseline,
    /// where V_in exerts no global force).
    pub vin: Option<(Arc<Segmentation>, VinForm)>,
    /// Helfrich bending (κ in Ē, C0 in 1/l̄).
    pub bending: Option<(f64, f64)>,
    /// Volume penalty k (Ē) and target V_t (l̄³): E = k (V − V_t)² / V_t.
    pub volume: Option<(f64, f64)>,
    /// Area penalty k (Ē) and target A_t (l̄²): E = k (A − A_t)² / A_t.
    pub area: Option<(f64, f64)>,
    /// Constant tension σ (Ē/l̄²): E = σ A.
    pub tension: Option<f64>,
    /// Control-point springs act on each point's nearest vertex and its
    /// 1-ring. A flip changes the 1-rings of its four vertices only, so
    /// forbidding flips that touch a nearest vertex leaves the springs'
    /// energy unchanged (nearest vertices depend on positions alone, so the
    /// rule is the same both ways).
    pub springs: bool,
}

/// The scene's energy terms a flip's ΔE includes, as declared (targets not
/// yet resolved; [`crate::systems::plugins::edge_flips`] resolves them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlipTerms {
    /// V_in, in the form its force uses (none where it exerts no force).
    pub vin: Option<VinForm>,
    /// Helfrich bending.
    pub bending: Option<crate::params::BendingParams>,
    /// Volume penalty.
    pub volume: Option<crate::params::VolumeParams>,
    /// Area penalty.
    pub area: Option<crate::params::AreaParams>,
    /// Constant tension.
    pub tension: Option<crate::params::TensionParams>,
    /// Control-point springs: flips never touch a point's nearest vertex.
    pub springs: bool,
}

/// A flip of one edge, in dense slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Flip {
    /// Edge slot of a–b.
    pub edge: u32,
    /// The edge's ends.
    pub a: u32,
    /// See `a`.
    pub b: u32,
    /// Opposite corner of the face (a, b, c).
    pub c: u32,
    /// Opposite corner of the face (b, a, d).
    pub d: u32,
    /// Face slots of (a, b, c) and (b, a, d).
    pub faces: [u32; 2],
}

impl Flip {
    /// The flip of edge slot `edge`, if its two faces exist and c ≠ d.
    pub fn of(t: &Topology, edge: u32) -> Option<Self> {
        let [f0, f1] = t.edge_faces[edge as usize];
        let [p, q] = t.edges[edge as usize];
        let mut abc = None;
        let mut bad = None;
        for f in [f0, f1] {
            let tri = t.faces.get(f as usize)?;
            // The face that traverses p → q is (a, b, c) with a = p.
            for k in 0..3 {
                if tri[k] == p && tri[(k + 1) % 3] == q {
                    abc = Some((f, tri[(k + 2) % 3]));
                } else if tri[k] == q && tri[(k + 1) % 3] == p {
                    bad = Some((f, tri[(k + 2) % 3]));
                }
            }
        }
        let ((fc, c), (fd, d)) = (abc?, bad?);
        (c != d).then_some(Self {
            edge,
            a: p,
            b: q,
            c,
            d,
            faces: [fc, fd],
        })
    }

    /// The two faces after the flip: (a, d, c) and (d, b, c).
    pub fn new_faces(&self) -> [[u32; 3]; 2] {
        [[self.a, self.d, self.c], [self.d, self.b, self.c]]
    }

    /// The two faces before the flip: (a, b, c) and (b, a, d).
    pub fn old_faces(&self) -> [[u32; 3]; 2] {
        [[self.a, self.b, self.c], [self.b, self.a, self.d]]
    }

    /// The flip as a mesh edit: its two faces out, the two new ones in
    /// (entities from `t`, the topology it was found in).
    pub fn edit(&self, t: &Topology) -> crate::mesh::edit::PatchEdit {
        let [a, b, c, d] = [self.a, self.b, self.c, self.d].map(|v| t.vertex_entities[v as usize]);
        crate::mesh::edit::PatchEdit {
            remove_faces: self.faces.map(|f| t.face_entities[f as usize]).to_vec(),
            add_faces: vec![[a, d, c], [d, b, c]],
            ..Default::default()
        }
    }
}

/// Unit normal of a triangle of positions (zero for a degenerate one).
fn normal(p: &[DVec3], f: [u32; 3]) -> DVec3 {
    let [a, b, c] = f.map(|i| p[i as usize]);
    (b - a).cross(c - a).normalize_or_zero()
}

/// Whether the flip keeps the surface unfolded both ways: the two faces
/// before and the two after each meet at a dihedral angle below 90° from
/// flat (n₁·n₂ > 0). Required in both states, so the rule is symmetric and
/// the reverse flip is allowed exactly when this one is.
pub fn keeps_surface_unfolded(flip: &Flip, positions: &[DVec3]) -> bool {
    let [o0, o1] = flip.old_faces();
    let [n0, n1] = flip.new_faces();
    normal(positions, o0).dot(normal(positions, o1)) > 0.0
        && normal(positions, n0).dot(normal(positions, n1)) > 0.0
}

/// Signed volume of the tetrahedron of a face and `origin` (l̄³).
fn face_volume(p: &[DVec3], f: [u32; 3], origin: DVec3) -> f64 {
    let [a, b, c] = f.map(|i| p[i as usize] - origin);
    a.dot(b.cross(c)) / 6.0
}

/// Area of a face (l̄²).
fn face_area(p: &[DVec3], f: [u32; 3]) -> f64 {
    let [a, b, c] = f.map(|i| p[i as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// Bending energy ½κ A (h − C0)² of vertex `v` over the faces `ring` (those
/// containing v), with h = s|L|/(2A) as in [`crate::energy::bending`].
fn vertex_bending(p: &[DVec3], v: u32, ring: &[[u32; 3]], kappa: f64, c0: f64) -> f64 {
    let (mut area, mut lap, mut nrm) = (0.0, DVec3::ZERO, DVec3::ZERO);
    for f in ring {
        let k = f
            .iter()
            .position(|&x| x == v)
            .expect("ring face contains v");
        let c = Corners::new(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]);
        area += c.mixed_areas()[k];
        lap += c.laplacian()[k];
        nrm += c.n_hat * c.twice_area;
    }
    let len = lap.length();
    let sign = if lap.dot(nrm) < 0.0 { -1.0 } else { 1.0 };
    let h = sign * len / (2.0 * area);
    0.5 * kappa * area * (h - c0) * (h - c0)
}

/// Running totals a flip's penalty terms need (updated as flips are taken).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipTotals {
    /// Enclosed volume (l̄³).
    pub volume: f64,
    /// Area (l̄²).
    pub area: f64,
}

impl FlipTotals {
    /// Volume and area of a closed mesh, as the penalties measure them.
    pub fn of(positions: &[DVec3], faces: &[[u32; 3]]) -> Self {
        let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
        Self {
            volume: crate::mesh::geometry::enclosed_volume(positions, faces, origin),
            area: crate::mesh::geometry::total_area(positions, faces),
        }
    }
}

/// The energy change of a flip and the totals after it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipChange {
    /// ΔE (Ē).
    pub energy: f64,
    /// Change of the enclosed volume (l̄³).
    pub volume: f64,
    /// Change of the area (l̄²).
    pub area: f64,
}

impl FlipEnergy {
    /// ΔE of `flip` at `positions` with the current `totals`.
    pub fn change(
        &self,
        flip: &Flip,
        t: &Topology,
        positions: &[DVec3],
        totals: FlipTotals,
    ) -> FlipChange {
        let p = positions;
        let old = flip.old_faces();
        let new = flip.new_faces();
        let mut energy = 0.0;
        if let Some((seg, form)) = &self.vin {
            let v = |l: f64| match form {
                VinForm::PiecewiseLinear => seg.linear(l).0,
                VinForm::Exact => seg.exact(l),
            };
            let ab = p[flip.a as usize].distance(p[flip.b as usize]);
            let cd = p[flip.c as usize].distance(p[flip.d as usize]);
            energy += v(cd) - v(ab);
        }
        if let Some((kappa, c0)) = self.bending {
            let mut ring = Vec::with_capacity(12);
            for v in [flip.a, flip.b, flip.c, flip.d] {
                ring.clear();
                ring.extend(
                    t.ring_faces_of(v as usize)
                        .iter()
                        .filter(|&&f| f != flip.faces[0] && f != flip.faces[1])
                        .map(|&f| t.faces[f as usize]),
                );
                let kept = ring.len();
                ring.extend(old.iter().filter(|f| f.contains(&v)));
                let before = vertex_bending(p, v, &ring, kappa, c0);
                ring.truncate(kept);
                ring.extend(new.iter().filter(|f| f.contains(&v)));
                let after = vertex_bending(p, v, &ring, kappa, c0);
                energy += after - before;
            }
        }
        // The four faces share one boundary, so ΔV does not depend on the
        // origin (here a corner, for round-off).
        let o = p[flip.a as usize];
        let dv = face_volume(p, new[0], o) + face_volume(p, new[1], o)
            - face_volume(p, old[0], o)
            - face_volume(p, old[1], o);
        let da = face_area(p, new[0]) + face_area(p, new[1])
            - face_area(p, old[0])
            - face_area(p, old[1]);
        let penalty = |k: f64, target: f64, x: f64, dx: f64| {
            k * ((x + dx - target).powi(2) - (x - target).powi(2)) / target
        };
        if let Some((k, target)) = self.volume {
            energy += penalty(k, target, totals.volume, dv);
        }
        if let Some((k, target)) = self.area {
            energy += penalty(k, target, totals.area, da);
        }
        if let Some(sigma) = self.tension {
            energy += sigma * da;
        }
        FlipChange {
            energy,
            volume: dv,
            area: da,
        }
    }
}
