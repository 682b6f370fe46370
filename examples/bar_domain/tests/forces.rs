//! The BAR-domain term's analytic force equals minus the finite-difference
//! gradient of its energy (the same check every built-in term passes), and
//! its energy reduces to Helfrich bending where the coverage is uniform.

use bar_domain::{BarDomainForces, Coverage};
use glam::DVec3;
use remembrane::energy::bending::BendingForces;
use remembrane::engine::force::{ForceContext, ForceTerm};
use remembrane::fd::{FdOptions, check_force_term};
use remembrane::mesh::SurfaceMesh;
use remembrane::mesh::membrane::Membrane;
use remembrane::mesh::vertex_field::TransferPolicy;
use remembrane::params::BendingParams;

/// Relative tolerance on the per-vertex force vector, as for the built-ins.
const REL_TOL: f64 = 1e-6;

/// The perturbed icosphere every term is checked on.
fn perturbed(level: u32, seed: u64) -> SurfaceMesh {
    remembrane::fd::perturbed_icosphere(level, seed)
}

/// A membrane whose coverage varies from vertex to vertex.
fn covered(mesh: &SurfaceMesh, coverage: impl Fn(usize) -> f64) -> (Membrane, Vec<DVec3>) {
    let mut m = Membrane::from_mesh(mesh, false).unwrap();
    m.add_vertex_field::<Coverage>("coverage", TransferPolicy::Interpolate, |slot, _| {
        coverage(slot)
    })
    .unwrap();
    m.topology().unwrap();
    let mut p = Vec::new();
    m.gather_positions(&mut p);
    (m, p)
}

#[test]
fn bar_domain_force_matches_finite_differences() {
    for (level, seed) in [(2, 41), (3, 42)] {
        let mesh = perturbed(level, seed);
        let (m, p) = covered(&mesh, |i| ((i * 7919) % 101) as f64 / 100.0);
        let mut term = BarDomainForces::new(5.0, 0.6);
        // As for the built-in term with spontaneous curvature: a step of
        // 1e-5 resolves the kink of |K| at 0.
        let options = FdOptions {
            step: 1e-5,
            rel_tol: REL_TOL,
            abs_floor: 1e-9,
            ..FdOptions::default()
        };
        let report = check_force_term(
            &mut term,
            &m.world,
            m.cached_topology(),
            &p,
            &[],
            None,
            options,
        );
        println!(
            "bar_domain ({} vertices): max rel err {:.2e}, max |F| {:.3e}",
            p.len(),
            report.max_rel_error,
            report.max_force
        );
        assert!(report.max_force > 1e-3);
        assert!(
            report.passed(),
            "{} vertices fail, first {:?}",
            report.failures.len(),
            report.failures.first()
        );
    }
}

fn energy(term: &mut dyn ForceTerm, m: &Membrane, p: &[DVec3]) -> f64 {
    let mut geometry = Vec::new();
    let ctx = ForceContext::new(&m.world, m.cached_topology(), p, &[], &mut geometry, true);
    term.energy(&ctx)
}

#[test]
fn uniform_coverage_is_helfrich_bending_with_that_spontaneous_curvature() {
    let mesh = perturbed(3, 5);
    // Full coverage: exactly the built-in term with C0 = C_p.
    let (m, p) = covered(&mesh, |_| 1.0);
    let bar = energy(&mut BarDomainForces::new(5.0, 0.6), &m, &p);
    let helfrich = energy(
        &mut BendingForces::new(BendingParams {
            kappa: 5.0,
            c0: 0.6,
            ..Default::default()
        }),
        &m,
        &p,
    );
    assert_eq!(bar, helfrich);
    // No coverage: the built-in term with C0 = 0 (its Σκ|L|²/8A form).
    let (m, p) = covered(&mesh, |_| 0.0);
    let bar = energy(&mut BarDomainForces::new(5.0, 0.6), &m, &p);
    let plain = energy(
        &mut BendingForces::new(BendingParams {
            kappa: 5.0,
            c0: 0.0,
            ..Default::default()
        }),
        &m,
        &p,
    );
    assert!((bar - plain).abs() < 1e-12 * plain, "{bar} vs {plain}");
}

/// The term without its local flip formula: the flip system prices it by
/// whole evaluations, the default every plugin term gets.
struct PricedWhole(BarDomainForces);

impl ForceTerm for PricedWhole {
    fn name(&self) -> &str {
        "bar_domain"
    }
    fn uses_face_geometry(&self) -> bool {
        true
    }
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        self.0.evaluate(ctx, force)
    }
}

/// The term takes part in Metropolis edge flips: its ΔE from the four
/// vertices a flip touches, and the flip system's whole-evaluation default,
/// both equal E after minus E before on a membrane whose coverage varies
/// from vertex to vertex (every 7th edge of a perturbed 642-vertex sphere,
/// each flip made through the mesh-edit layer and undone).
#[test]
fn bar_domain_flip_energy_change_is_the_whole_energy_difference() {
    let mesh = perturbed(3, 43);
    let (mut m, p) = covered(&mesh, |i| ((i * 7919) % 101) as f64 / 100.0);
    let ways: [(&str, Box<dyn ForceTerm>); 2] = [
        ("its own formula", Box::new(BarDomainForces::new(5.0, 0.6))),
        (
            "whole evaluations",
            Box::new(PricedWhole(BarDomainForces::new(5.0, 0.6))),
        ),
    ];
    for (way, mut term) in ways {
        let r = remembrane::fd::check_flip_energy_change(&mut term, &mut m, &p, &[], 7);
        println!("bar_domain flips by {way}: {r:?}");
        assert!(r.flips > 200, "{way}: {r:?}");
        assert!(r.max_error <= 1e-10 * r.scale, "{way}: {r:?}");
    }
}
