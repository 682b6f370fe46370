//! Finite-difference verification of force terms, public so plugin authors
//! can check their own [`ForceTerm`]s the same way the built-in ones are.
//!
//! For every vertex and Cartesian component the energy is evaluated at
//! displaced positions and the central-difference derivative compared with
//! the analytic force. A vertex passes when
//! |F_analytic − F_fd| ≤ `rel_tol`·|F_fd| + `abs_floor`.

use crate::engine::force::{ForceContext, ForceTerm};
use crate::mesh::topology::Topology;
use glam::DVec3;
use hecs::World;

/// Difference stencil.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stencil {
    /// (E(x+h) − E(x−h)) / 2h: exact for piecewise-linear energies when the
    /// step does not cross a breakpoint; truncation error O(h²).
    Central2,
    /// (E(x−2h) − 8E(x−h) + 8E(x+h) − E(x+2h)) / 12h; truncation error O(h⁴),
    /// so a larger h (smaller round-off) reaches the same accuracy.
    Central4,
}

/// Options of a finite-difference check.
#[derive(Clone, Copy, Debug)]
pub struct FdOptions {
    /// Displacement h (l̄).
    pub step: f64,
    /// Stencil.
    pub stencil: Stencil,
    /// Allowed relative error of the per-vertex force vector.
    pub rel_tol: f64,
    /// Absolute error allowed on top (Ē/l̄): the round-off floor of the
    /// difference quotient, ≈ ε_machine·|E|/h, for vertices whose force is ≈ 0.
    pub abs_floor: f64,
}

impl Default for FdOptions {
    /// Fourth-order stencil, h = 1e-4 l̄, rel. tol. 1e-6, floor 1e-9 Ē/l̄.
    fn default() -> Self {
        Self {
            step: 1e-4,
            stencil: Stencil::Central4,
            rel_tol: 1e-6,
            abs_floor: 1e-9,
        }
    }
}

/// Outcome of a finite-difference check.
#[derive(Clone, Debug, Default)]
pub struct FdReport {
    /// Vertices checked.
    pub vertices: usize,
    /// Vertices that failed the tolerance.
    pub failures: Vec<FdFailure>,
    /// Largest relative error |ΔF|/|F_fd| among vertices with |F_fd| > floor.
    pub max_rel_error: f64,
    /// Largest absolute error |ΔF| (Ē/l̄).
    pub max_abs_error: f64,
    /// Largest |F_fd| seen (Ē/l̄), for scale.
    pub max_force: f64,
}

/// One vertex whose analytic force disagrees with the finite difference.
#[derive(Clone, Debug)]
pub struct FdFailure {
    /// Dense vertex slot.
    pub vertex: usize,
    /// Analytic force.
    pub analytic: DVec3,
    /// Finite-difference force (−∇E).
    pub numeric: DVec3,
}

impl FdReport {
    /// Whether every vertex passed.
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

/// A term's [`ForceTerm::normal_stiffness`] summed over the vertices, and
/// the second central difference (step `step`) of its energy under a
/// translation of the whole membrane along `direction` (a unit vector): the
/// two agree when every vertex's normal displacement is the translation
/// (a plane substrate or wall along `direction`) and the term's energy is
/// convex along it there.
pub fn normal_stiffness_against_translation(
    term: &mut dyn ForceTerm,
    world: &World,
    topology: &Topology,
    positions: &[DVec3],
    direction: DVec3,
    step: f64,
) -> (f64, f64) {
    let mut geometry = Vec::new();
    let mut energy = |t: f64| {
        let moved: Vec<DVec3> = positions.iter().map(|&x| x + direction * t).collect();
        let with_geometry = term.uses_face_geometry();
        let ctx = ForceContext::new(world, topology, &moved, &[], &mut geometry, with_geometry);
        term.energy(&ctx)
    };
    let fd = (energy(step) - 2.0 * energy(0.0) + energy(-step)) / (step * step);
    let ctx = ForceContext::new(world, topology, positions, &[], &mut geometry, false);
    let mut stiffness = vec![0.0; positions.len()];
    term.normal_stiffness(&ctx, &mut stiffness);
    (stiffness.iter().sum(), fd)
}

/// `term`'s energy and force at `positions` (faces' `geometry` given) with
/// the term inputs `inputs`, as the schedule's force pass would evaluate it
/// (no lipid field): for tests of what a term reads from the inputs.
pub fn evaluate_with_inputs(
    term: &mut dyn ForceTerm,
    world: &World,
    topology: &Topology,
    positions: &[DVec3],
    geometry: &[crate::mesh::geometry::Corners],
    inputs: &crate::engine::term_inputs::TermInputs,
) -> (f64, Vec<DVec3>) {
    let mut force = vec![DVec3::ZERO; positions.len()];
    let ctx = ForceContext {
        world,
        topology,
        positions,
        lipid: &[],
        face_geometry: geometry,
        inputs,
    };
    let energy = term.evaluate(&ctx, Some(&mut force));
    (energy, force)
}

/// Checks `term`'s analytic force against finite differences of its energy
/// at every vertex (or at the `vertices` given).
pub fn check_force_term(
    term: &mut dyn ForceTerm,
    world: &World,
    topology: &Topology,
    positions: &[DVec3],
    lipid: &[f64],
    vertices: Option<&[usize]>,
    options: FdOptions,
) -> FdReport {
    let with_geometry = term.uses_face_geometry();
    let mut geometry = Vec::new();
    let mut analytic = vec![DVec3::ZERO; positions.len()];
    {
        let ctx = ForceContext::new(
            world,
            topology,
            positions,
            lipid,
            &mut geometry,
            with_geometry,
        );
        term.accumulate(&ctx, &mut analytic);
    }

    let mut work = positions.to_vec();
    let all: Vec<usize>;
    let list = match vertices {
        Some(v) => v,
        None => {
            all = (0..positions.len()).collect();
            &all
        }
    };
    let h = options.step;
    let mut report = FdReport {
        vertices: list.len(),
        ..Default::default()
    };
    for &v in list {
        let mut numeric = DVec3::ZERO;
        for c in 0..3 {
            let mut energy_at = |offset: f64, work: &mut Vec<DVec3>| {
                work[v][c] = positions[v][c] + offset;
                let ctx =
                    ForceContext::new(world, topology, work, lipid, &mut geometry, with_geometry);
                let e = term.energy(&ctx);
                work[v][c] = positions[v][c];
                e
            };
            let derivative = match options.stencil {
                Stencil::Central2 => {
                    (energy_at(h, &mut work) - energy_at(-h, &mut work)) / (2.0 * h)
                }
                Stencil::Central4 => {
                    (energy_at(-2.0 * h, &mut work) - 8.0 * energy_at(-h, &mut work)
                        + 8.0 * energy_at(h, &mut work)
                        - energy_at(2.0 * h, &mut work))
                        / (12.0 * h)
                }
            };
            numeric[c] = -derivative;
        }
        let err = (analytic[v] - numeric).length();
        let scale = numeric.length();
        report.max_abs_error = report.max_abs_error.max(err);
        report.max_force = report.max_force.max(scale);
        if scale > options.abs_floor {
            report.max_rel_error = report.max_rel_error.max(err / scale);
        }
        if err > options.rel_tol * scale + options.abs_floor {
            report.failures.push(FdFailure {
                vertex: v,
                analytic: analytic[v],
                numeric,
            });
        }
    }
    report
}

/// Perturbation amplitude of [`perturbed_icosphere`] (l̄): large enough that
/// no symmetry hides an error, small enough that the mesh stays acute.
pub const TEST_PERTURBATION: f64 = 0.05;

/// The test mesh every built-in term is checked on: an icosphere of
/// `level` (mean edge 1 l̄) whose coordinates are shifted by a seeded
/// uniform jitter in ±[`TEST_PERTURBATION`].
pub fn perturbed_icosphere(level: u32, seed: u64) -> crate::mesh::SurfaceMesh {
    let mut mesh = crate::mesh::icosphere(level, 1.0);
    mesh.jitter(2.0 * TEST_PERTURBATION, seed);
    mesh.translate(DVec3::splat(-TEST_PERTURBATION));
    mesh
}

/// The open test patches every term that runs on open meshes is checked
/// on (boundary vertices included): a spherical cap (radius 4 l̄, opening
/// 70°, 91 vertices) and a flat disc (radius 4 l̄, 61 vertices), both of
/// mean edge about 1 l̄, shifted by the seeded jitter of
/// [`perturbed_icosphere`].
pub fn perturbed_patches(seed: u64) -> [crate::mesh::SurfaceMesh; 2] {
    [
        crate::mesh::spherical_cap(4.0, 70.0, 1.0),
        crate::mesh::disc(4.0, 1.0),
    ]
    .map(|mut mesh| {
        mesh.jitter(2.0 * TEST_PERTURBATION, seed);
        mesh.translate(DVec3::splat(-TEST_PERTURBATION));
        mesh
    })
}

/// The result of [`check_flip_energy_change`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlipCheckReport {
    /// Flips checked.
    pub flips: usize,
    /// The largest |priced ΔE − (E_after − E_before)| (Ē).
    pub max_error: f64,
    /// The largest |E| seen, the scale for a relative tolerance (Ē).
    pub scale: f64,
}

/// Checks how `term` prices edge flips (its
/// [`ForceTerm::flip_energy_change`], or the flip system's whole-energy
/// default when it returns `None`) against whole-energy differences. For
/// every `stride`-th edge of `membrane` whose flip the edit layer accepts
/// (valences 3 to 12), the priced ΔE is compared with E after minus E
/// before, the flip made through the mesh-edit layer and then undone by
/// flipping the new edge back. `positions` and `lipid` are by dense slot
/// (slots of vertices do not change under flips).
pub fn check_flip_energy_change(
    term: &mut Box<dyn ForceTerm>,
    membrane: &mut crate::mesh::membrane::Membrane,
    positions: &[DVec3],
    lipid: &[f64],
    stride: usize,
) -> FlipCheckReport {
    use crate::engine::force::FlipProposal;
    use crate::mesh::flip::{Flip, FlipTotals};
    let range = crate::mesh::ValenceRange { min: 3, max: 12 };
    let mut pricer = crate::remesh::flip::FlipPricer::default();
    let mut report = FlipCheckReport::default();
    let edges = membrane.cached_topology().edges.len();
    let mut geometry = Vec::new();
    for edge in (0..edges as u32).step_by(stride.max(1)) {
        let t = membrane.cached_topology();
        let Some(flip) = Flip::of(t, edge) else {
            continue;
        };
        let (c, d) = (flip.c, flip.d);
        if t.edge_between(c, d).is_some() {
            continue;
        }
        let before = whole_energy(term, membrane, positions, lipid, &mut geometry);
        let t = membrane.cached_topology();
        let totals = FlipTotals::of(positions, &t.faces);
        let proposal = FlipProposal::new(flip, &membrane.world, t, positions, lipid, totals);
        pricer.invalidate();
        let priced = pricer.change(std::slice::from_mut(term), &proposal);
        let edit = flip.edit(t);
        if membrane.apply_patch(&edit, range).is_err() {
            continue;
        }
        let after = whole_energy(term, membrane, positions, lipid, &mut geometry);
        report.flips += 1;
        report.max_error = report.max_error.max((priced - (after - before)).abs());
        report.scale = report.scale.max(before.abs()).max(after.abs());
        let t = membrane.cached_topology();
        let back = t
            .edge_between(c, d)
            .and_then(|e| Flip::of(t, e))
            .expect("the new edge c–d flips back");
        membrane
            .apply_patch(&back.edit(t), range)
            .expect("flipping back restores a valid mesh");
    }
    report
}

/// `term`'s energy on `membrane` at `positions`.
fn whole_energy(
    term: &mut Box<dyn ForceTerm>,
    membrane: &crate::mesh::membrane::Membrane,
    positions: &[DVec3],
    lipid: &[f64],
    geometry: &mut Vec<crate::mesh::geometry::Corners>,
) -> f64 {
    let t = membrane.cached_topology();
    let ctx = ForceContext::new(&membrane.world, t, positions, lipid, geometry, true);
    term.energy(&ctx)
}
