#![allow(missing_docs)]
//! The Sobolev minimiser's hot path at 2562 … 40962 vertices (a jittered
//! sphere, area and volume held): the factorisation of its metric
//! (`sobolev_factorise`, assembly and numeric factor, the analysis kept)
//! and one preconditioned direction (`sobolev_direction`: the normals, the
//! six-column and the three-column solve, the constraint columns and
//! their multipliers) on one and on two threads. From 2000 vertices the
//! solves split over two subtrees of the elimination tree
//! (`remembrane::minimise::cholesky`), with the same bits on any thread
//! count.
//!
//! `cargo bench -p remembrane-benches --bench minimiser`; filter with e.g.
//! `-- direction/10242`.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use glam::DVec3;
use remembrane::constraint::{ConstraintTargets, Gradients};
use remembrane::mesh::icosphere;
use remembrane::mesh::membrane::Membrane;
use remembrane::minimise::sobolev::{MetricScales, SobolevMetric};
use std::hint::black_box;
use std::time::Duration;

const SCALES: MetricScales = MetricScales {
    normal: 5.0,
    tangential: 0.2,
};

fn configure<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut g = c.benchmark_group(name);
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(20);
    g
}

fn sobolev(c: &mut Criterion) {
    for level in [4u32, 5, 6] {
        let mut mesh = icosphere(level, 1.0);
        mesh.jitter(0.05, 9);
        let mut membrane = Membrane::from_mesh(&mesh, false).unwrap();
        let topology = membrane.topology().unwrap().clone();
        let x = mesh.positions.clone();
        let n = x.len();
        let mut gradients = Gradients::default();
        gradients.measure(&x, &topology.faces);
        let targets = ConstraintTargets {
            area: Some(gradients.area),
            volume: Some(gradients.volume),
        };
        let force: Vec<DVec3> = (0..n)
            .map(|i| {
                let t = i as f64;
                DVec3::new(t.sin(), (1.3 * t).cos(), (0.7 * t).sin())
            })
            .collect();
        let mut metric = SobolevMetric::default();
        metric.build(&x, &topology, SCALES, &[]).unwrap();
        let mut g = configure(c, "sobolev_factorise");
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| metric.build(black_box(&x), &topology, SCALES, &[]).unwrap())
        });
        g.finish();
        let mut g = configure(c, "sobolev_direction");
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut d = Vec::new();
            g.bench_with_input(
                BenchmarkId::new(format!("{threads}_threads"), n),
                &n,
                |b, _| {
                    b.iter(|| {
                        pool.install(|| {
                            metric.direction(
                                &x,
                                &topology,
                                black_box(&force),
                                Some((&gradients, targets)),
                                &mut |_| {},
                                &mut d,
                            )
                        })
                    })
                },
            );
        }
        g.finish();
    }
}

criterion_group!(benches, sobolev);
criterion_main!(benches);
