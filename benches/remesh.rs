//! Remeshing throughput: one split and one merge through the mesh-edit
//! layer (enumeration, checks, world edit, topology rebuild) and one split
//! pre-relaxation of a stretched edge (V_in + Lévy kicks).
//!
//! `cargo bench --bench remesh`.
#![allow(missing_docs)]

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use remembrane::energy::vin::{Segmentation, VinParams};
use remembrane::membrane::Membrane;
use remembrane::mesh::{ValenceRange, icosphere};
use remembrane::relax::{Goal, KickTable, Patch, RelaxSettings, relax, rings};
use remembrane::remesh::{merge_edge, split_edge};
use std::hint::black_box;

const RANGE: ValenceRange = ValenceRange { min: 5, max: 8 };

fn membrane(level: u32) -> Membrane {
    let mut m = Membrane::from_mesh(&icosphere(level, 1.0), true).unwrap();
    m.topology().unwrap();
    m
}

fn topology_ops(c: &mut Criterion) {
    for level in [3, 5] {
        let n = remembrane::mesh::vertex_count_for_level(level);
        c.bench_function(&format!("split_edge/{n}"), |b| {
            b.iter_batched(
                || membrane(level),
                |mut m| black_box(split_edge(&mut m, 100, RANGE).is_ok()),
                BatchSize::LargeInput,
            )
        });
        c.bench_function(&format!("merge_edge/{n}"), |b| {
            b.iter_batched(
                || membrane(level),
                |mut m| black_box(merge_edge(&mut m, 100, ValenceRange { min: 4, max: 9 }).is_ok()),
                BatchSize::LargeInput,
            )
        });
    }
}

fn pre_relaxation(c: &mut Criterion) {
    let seg = Segmentation::new(VinParams::default());
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

criterion_group!(benches, topology_ops, pre_relaxation);
criterion_main!(benches);
