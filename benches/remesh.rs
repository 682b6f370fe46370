//! Remeshing throughput: one split and one merge through the mesh-edit
//! layer (enumeration, checks, world edit, incremental topology update; the
//! membrane is built, warmed by one earlier split and dropped outside the
//! timing) at 642, 10242 and
//! 40962 vertices, and one split pre-relaxation of a stretched edge (V_in +
//! Lévy kicks). Edge flips: the energy change of one proposal (V_in,
//! bending, volume, area) and one flip through the mesh-edit layer.
//!
//! `cargo bench -p remembrane-benches --bench remesh`.
#![allow(missing_docs)]

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use remembrane::energy::vin::{Segmentation, VinParams};
use remembrane::mesh::membrane::Membrane;
use remembrane::mesh::{ValenceRange, icosphere};
use remembrane::remesh::relax::{Goal, KickTable, Patch, RelaxSettings, relax, rings};
use remembrane::remesh::{merge_edge, split_edge};
use std::hint::black_box;
use std::time::{Duration, Instant};

const RANGE: ValenceRange = ValenceRange { min: 5, max: 8 };

fn membrane(level: u32) -> Membrane {
    let mut m = Membrane::from_mesh(&icosphere(level, 1.0), true).unwrap();
    m.topology().unwrap();
    m
}

/// A membrane after one split far from edge 100, so the per-slot arrays and
/// the world's storage have grown once (their capacity doubles): the edit
/// timed next is a steady-state one, not the first edit's one-off O(N)
/// reallocation.
fn warmed_membrane(level: u32) -> Membrane {
    let mut m = membrane(level);
    let far = (m.cached_topology().edges.len() / 2) as u32;
    split_edge(&mut m, far, RANGE).unwrap();
    m
}

fn topology_ops(c: &mut Criterion) {
    for level in [3, 5, 6] {
        let n = remembrane::mesh::vertex_count_for_level(level);
        c.bench_function(&format!("split_edge/{n}"), |b| {
            b.iter_batched(
                || warmed_membrane(level),
                |mut m| {
                    let ok = split_edge(&mut m, 100, RANGE).is_ok();
                    (black_box(ok), m)
                },
                BatchSize::LargeInput,
            )
        });
        c.bench_function(&format!("merge_edge/{n}"), |b| {
            b.iter_batched(
                || warmed_membrane(level),
                |mut m| {
                    let ok = merge_edge(&mut m, 100, ValenceRange { min: 4, max: 9 }).is_ok();
                    (black_box(ok), m)
                },
                BatchSize::LargeInput,
            )
        });
    }
}

/// An edge whose flip is valid on a level-`level` icosphere (its ends have
/// valence 6, so they may lose one), and the flip.
fn flippable_edge(m: &Membrane) -> remembrane::remesh::flip::Flip {
    use remembrane::remesh::flip::Flip;
    let t = m.cached_topology();
    (100..t.edges.len() as u32)
        .filter_map(|e| Flip::of(t, e))
        .find(|f| t.valence(f.a as usize) == 6 && t.valence(f.b as usize) == 6)
        .expect("an edge between two valence-6 vertices")
}

fn edge_flips(c: &mut Criterion) {
    use remembrane::energy::area::AreaForces;
    use remembrane::energy::bending::BendingForces;
    use remembrane::energy::vin::VinForces;
    use remembrane::energy::volume::VolumeForces;
    use remembrane::engine::force::{FlipProposal, ForceTerm};
    use remembrane::remesh::flip::{FlipPricer, FlipTotals};
    use std::sync::Arc;
    let mesh = icosphere(3, 1.0);
    let m = membrane(3);
    let t = m.cached_topology();
    let flip = flippable_edge(&m);
    let totals = FlipTotals::of(&mesh.positions, &t.faces);
    let mut terms: Vec<Box<dyn ForceTerm>> = vec![
        Box::new(VinForces::new(
            Arc::new(Segmentation::new(VinParams::default())),
            remembrane::energy::vin::VinForm::PiecewiseLinear,
        )),
        Box::new(BendingForces::new(remembrane::params::BendingParams {
            kappa: 1.5,
            ..Default::default()
        })),
        Box::new(VolumeForces::new(1.0, totals.volume)),
        Box::new(AreaForces::new(20.0, totals.area)),
    ];
    let proposal = FlipProposal::new(flip, &m.world, t, &mesh.positions, &[], totals);
    let mut pricer = FlipPricer::default();
    c.bench_function("flip_energy_change/642", |b| {
        b.iter(|| black_box(pricer.change(&mut terms, black_box(&proposal))))
    });
    for level in [3, 6] {
        let n = remembrane::mesh::vertex_count_for_level(level);
        c.bench_function(&format!("flip_edit/{n}"), |b| {
            b.iter_batched(
                || {
                    let m = warmed_membrane(level);
                    let edit = flippable_edge(&m).edit(m.cached_topology());
                    (m, edit)
                },
                |(mut m, edit)| {
                    let ok = m.apply_patch(&edit, RANGE).is_ok();
                    (black_box(ok), m)
                },
                BatchSize::LargeInput,
            )
        });
    }
}

/// The 1-ring patch of an icosphere edge stretched by 40 % (1.4 l̄, past
/// l_+), and the as-run relaxation settings.
fn stretched_edge_patch() -> (Patch, RelaxSettings) {
    let mesh = icosphere(3, 1.0);
    let m = membrane(3);
    let t = m.cached_topology();
    let [a, b] = t.edges[100];
    let moveable = rings(t, &[a, b], 1);
    let (mut patch, _) = Patch::around(t, &mesh.positions, &moveable, Some([a, b]));
    let d = patch.positions[1] - patch.positions[0];
    patch.positions[0] -= 0.2 * d;
    patch.positions[1] += 0.2 * d;
    let settings = RelaxSettings {
        normal: (0.8, 1.2),
        kick_scale: 10.0,
        mobility: 1000.0,
        max_iterations: 50_000,
    };
    (patch, settings)
}

fn pre_relaxation(c: &mut Criterion) {
    let seg = Segmentation::new(VinParams::default());
    let (patch, settings) = stretched_edge_patch();
    let kicks = KickTable::new(&mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(7));
    let mut seed = 0;
    c.bench_function("split_pre_relaxation/642", |bench| {
        bench.iter_batched(
            || {
                seed += 1;
                (
                    patch.clone(),
                    rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed),
                )
            },
            |(mut p, mut rng)| {
                black_box(relax(
                    &mut p,
                    Goal::Extend(1.8),
                    &seg,
                    &settings,
                    &kicks,
                    &mut rng,
                ))
            },
            BatchSize::SmallInput,
        )
    });
}

/// Cost of one relaxation iteration, independent of how many iterations a
/// relaxation needs: the reported time is per 1000 iterations, summed over
/// split pre-relaxations of the stretched edge with varying seeds.
fn relaxation_iteration(c: &mut Criterion) {
    let seg = Segmentation::new(VinParams::default());
    let (patch, settings) = stretched_edge_patch();
    let kicks = KickTable::new(&mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(7));
    let mut seed = 0;
    let name = format!("relaxation_per_1000_iterations/{}_edges", patch.edges.len());
    c.bench_function(&name, |bench| {
        bench.iter_custom(|calls| {
            let mut iterations = 0u64;
            let mut elapsed = Duration::ZERO;
            for _ in 0..calls {
                seed += 1;
                let mut p = patch.clone();
                let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
                let start = Instant::now();
                let relaxed = relax(&mut p, Goal::Extend(1.8), &seg, &settings, &kicks, &mut rng);
                elapsed += start.elapsed();
                iterations += u64::from(black_box(relaxed).iterations);
            }
            elapsed.mul_f64(1000.0 * calls as f64 / iterations as f64)
        })
    });
}

criterion_group!(
    benches,
    topology_ops,
    edge_flips,
    pre_relaxation,
    relaxation_iteration
);
criterion_main!(benches);
