//! Closed-form values: sphere bending energy against the discrete reference
//! values (../shared/peers), exact polyhedral area and volume, radius
//! independence, and the V_in shape and segmentation (SPEC §2-3).

use glam::DVec3;
use remembrane::energy::bending::{BendingScratch, bending};
use remembrane::energy::vin::{Segmentation, VinParams};
use remembrane::mesh::geometry::{enclosed_volume, reduced_volume, total_area};
use remembrane::mesh::{icosphere, icosphere_unit};
use std::f64::consts::PI;

fn bending_of(mesh: &remembrane::mesh::SurfaceMesh, kappa: f64, c0: f64) -> f64 {
    let mut geometry = Vec::new();
    remembrane::mesh::geometry::face_geometry(&mesh.positions, &mesh.faces, &mut geometry);
    let n = mesh.vertex_count();
    bending(
        n,
        &mesh.faces,
        &geometry,
        kappa,
        c0,
        &mut BendingScratch::default(),
        None,
    )
}

/// Discrete cotangent/mixed-Voronoi bending energy of the level-n icosphere
/// with κ = 1 (reference values from Mem3DG's harness, ../shared/peers).
const SPHERE_BENDING: [(u32, f64); 4] = [
    (2, 24.662632),
    (3, 25.013576),
    (4, 25.102796),
    (5, 25.125239),
];
/// Tolerance on those six-digit reference values.
const BENDING_TOL: f64 = 1e-3;

fn bending_energy(level: u32, scale: f64) -> f64 {
    let mut mesh = icosphere(level, 1.0);
    mesh.scale(scale);
    bending_of(&mesh, 1.0, 0.0)
}

#[test]
fn sphere_bending_energy_matches_discrete_reference_and_converges() {
    let mut previous_error = None;
    for (level, reference) in SPHERE_BENDING {
        let e = bending_energy(level, 1.0);
        let error = e - 8.0 * PI;
        println!("level {level}: E = {e:.6}, E − 8π = {error:.3e}");
        assert!(
            (e - reference).abs() < BENDING_TOL,
            "level {level}: {e} vs {reference}"
        );
        if let Some(prev) = previous_error {
            let ratio: f64 = prev / error;
            assert!(
                (3.8..4.2).contains(&ratio),
                "error ratio {ratio} per level, expected ≈ 4"
            );
        }
        previous_error = Some(error);
    }
    // 642 vertices: −4.74e-3 relative to 8π.
    let rel = (bending_energy(3, 1.0) - 8.0 * PI) / (8.0 * PI);
    assert!((rel + 4.74e-3).abs() < 1e-5, "relative error {rel}");
}

#[test]
fn bending_energy_is_independent_of_radius() {
    let e1 = bending_energy(3, 1.0);
    for scale in [0.01, 0.37, 10.0, 1e3] {
        let e = bending_energy(3, scale);
        assert!((e - e1).abs() < 1e-10 * e1, "scale {scale}: {e} vs {e1}");
    }
}

#[test]
fn spherical_spontaneous_curvature_energy() {
    // ½κ Σ A_i (|K_i| − C0)² on a sphere with K_i ≈ 2/R: zero when C0 = 2/R.
    let mesh = icosphere(4, 1.0);
    let r = mesh.positions.iter().map(|p| p.length()).sum::<f64>() / mesh.vertex_count() as f64;
    let e = |c0| bending_of(&mesh, 1.0, c0);
    let at_match = e(2.0 / r);
    assert!(
        at_match < 1e-3 * e(0.0),
        "C0 = 2/R: {at_match} vs C0 = 0: {}",
        e(0.0)
    );
    // C0 = −2/R doubles the curvature mismatch: 4× the C0 = 0 energy.
    assert!((e(-2.0 / r) / e(0.0) - 4.0).abs() < 1e-2);
}

#[test]
fn polyhedral_area_and_volume_are_exact() {
    // A regular icosahedron with edge a: A = 5√3 a², V = 5(3+√5)/12 a³.
    let ico = icosphere_unit(0);
    let a = ico.mean_edge_length();
    let area = total_area(&ico.positions, &ico.faces);
    let volume = enclosed_volume(&ico.positions, &ico.faces, DVec3::ZERO);
    assert!((area - 5.0 * 3f64.sqrt() * a * a).abs() < 1e-12 * area);
    assert!((volume - 5.0 * (3.0 + 5f64.sqrt()) / 12.0 * a.powi(3)).abs() < 1e-12 * volume);
    // Origin independence for a closed mesh.
    let shifted = enclosed_volume(&ico.positions, &ico.faces, DVec3::new(100.0, -50.0, 3.0));
    assert!((shifted - volume).abs() < 1e-9 * volume);

    // The 642-vertex scene sphere (reference §7: R 6.634, A 550.48, V 1212.66).
    let m = icosphere(3, 1.0);
    let r = m.positions[0].length();
    assert_eq!(m.vertex_count(), 642);
    assert_eq!(m.faces.len(), 1280);
    assert_eq!(m.edges().len(), 1920);
    assert!((r - 6.634).abs() < 5e-4, "radius {r}");
    let area = total_area(&m.positions, &m.faces);
    let volume = enclosed_volume(&m.positions, &m.faces, DVec3::ZERO);
    assert!((area - 550.48).abs() < 0.01, "area {area}");
    assert!((volume - 1212.66).abs() < 0.01, "volume {volume}");
    // A subdivided sphere converges to the smooth sphere: v → 1 from below.
    let v = reduced_volume(volume, area);
    assert!(v < 1.0 && v > 0.995, "reduced volume {v}");
}

#[test]
fn icosphere_counts() {
    for level in 0..=5 {
        let m = icosphere_unit(level);
        assert_eq!(
            m.vertex_count(),
            remembrane::mesh::vertex_count_for_level(level)
        );
        remembrane::mesh::check_mesh(
            &m.positions,
            &m.faces,
            Some(remembrane::mesh::ValenceRange { min: 5, max: 6 }),
        )
        .unwrap();
    }
}

#[test]
fn vin_shape_matches_as_run_reference() {
    let seg = Segmentation::new(VinParams::default());
    let v = |l| seg.exact(l);
    // Minima at 0.0230, 1.000, 2.0989 (found on the 1e-4 grid).
    let local_min = |lo: f64, hi: f64| {
        let n = ((hi - lo) / 1e-4) as usize;
        (0..=n)
            .map(|k| lo + k as f64 * 1e-4)
            .min_by(|a, b| v(*a).total_cmp(&v(*b)))
            .unwrap()
    };
    assert!((local_min(0.001, 0.2) - 0.0230).abs() < 1.5e-4);
    assert!((local_min(0.8, 1.2) - 1.000).abs() < 1.5e-4);
    assert!((local_min(1.9, 2.19) - 2.0989).abs() < 1.5e-4);
    assert!(
        v(2.0989).abs() < 1e-6,
        "global minimum is 0 after the offset"
    );
    for (l, expected) in [(0.7, 0.0777), (1.3, 0.0777), (0.75, 0.05), (1.25, 0.05)] {
        assert!((v(l) - expected).abs() < 5e-5, "V({l}) = {}", v(l));
    }
    // The analytic derivative agrees with the function.
    for l in [0.03, 0.3, 0.77, 1.0, 1.31, 1.6, 2.1] {
        let fd = (v(l + 1e-6) - v(l - 1e-6)) / 2e-6;
        let d = seg.params().derivative(l);
        assert!(
            (fd - d).abs() < 1e-6 * d.abs().max(1.0),
            "V'({l}) {d} vs {fd}"
        );
    }
}

#[test]
fn vin_segmentation_gives_438_segments_satisfying_both_criteria() {
    let p = VinParams::default();
    let seg = Segmentation::new(p);
    assert_eq!(seg.segment_count(), 438);
    // Paper thresholds (σ < 0.001·V0) give 1349.
    let paper = Segmentation::new(VinParams {
        segment_std_max: 0.001 * p.v0,
        ..p
    });
    assert_eq!(paper.segment_count(), 1349);
    // Every segment with ≥ 3 samples satisfies R² ≥ 0.5 and std ≤ σ_max
    // (two-sample segments are lines by construction and cannot split).
    let b = &seg.breakpoints;
    for s in 0..seg.segment_count() {
        let samples: Vec<(f64, f64)> = {
            let n = ((b[s + 1] - b[s]) / p.dl).round() as usize;
            (0..=n)
                .map(|k| b[s] + k as f64 * p.dl)
                .map(|l| (l, seg.exact(l)))
                .collect()
        };
        if samples.len() < 3 {
            continue;
        }
        let n = samples.len() as f64;
        let mx = samples.iter().map(|s| s.0).sum::<f64>() / n;
        let my = samples.iter().map(|s| s.1).sum::<f64>() / n;
        let sxx: f64 = samples.iter().map(|s| (s.0 - mx).powi(2)).sum();
        let syy: f64 = samples.iter().map(|s| (s.1 - my).powi(2)).sum();
        let sxy: f64 = samples.iter().map(|s| (s.0 - mx) * (s.1 - my)).sum();
        let std = (syy / (n - 1.0)).sqrt();
        assert!(
            std <= p.segment_std_max * (1.0 + 1e-9),
            "segment {s}: std {std}"
        );
        if syy > 0.0 {
            let r2 = sxy * sxy / (sxx * syy);
            assert!(r2 >= p.segment_r2_min, "segment {s}: R² {r2}");
        }
    }
    // The piecewise-linear V_in interpolates the samples at breakpoints and
    // is continuous.
    for s in 1..seg.segment_count() {
        let l = b[s];
        let (left, slope_left) = seg.linear(l);
        let (right, slope_right) = seg.linear(l + 1e-12);
        // Next to the walls the chord slope reaches ~1e5 Ē/l̄.
        let tol = 1e-12 + 2e-12 * slope_left.abs().max(slope_right.abs());
        assert!(
            (left - right).abs() < tol,
            "breakpoint {s}: {left} vs {right}"
        );
        assert!((left - seg.exact(l)).abs() < 1e-12);
    }
}

/// The segment lookup (a coarse bin table plus a one-breakpoint correction)
/// agrees with a search of the breakpoints everywhere: at every breakpoint,
/// one ulp either side of it, and on a dense grid, for the as-run and the
/// paper-threshold segmentations; lengths outside the sampled range map to
/// the end segments.
#[test]
fn vin_segment_lookup_matches_a_breakpoint_search() {
    let p = VinParams::default();
    for seg in [
        Segmentation::new(p),
        Segmentation::new(VinParams {
            segment_std_max: 0.001 * p.v0,
            ..p
        }),
    ] {
        let b = &seg.breakpoints;
        let last = seg.segment_count() - 1;
        // Segment s is (b_s, b_{s+1}]; below b_1 → 0, above b_last → last.
        let search = |l: f64| b[1..=last].partition_point(|&x| x < l);
        let mut probes: Vec<f64> = Vec::new();
        for &x in b.iter() {
            probes.extend([x.next_down(), x, x.next_up()]);
        }
        probes.extend((0..200_000).map(|k| -0.1 + 2.4 * k as f64 / 200_000.0));
        for l in probes {
            assert_eq!(seg.segment_of(l), search(l), "l = {l:e}");
        }
        assert_eq!(seg.segment_of(f64::NAN), 0);
        assert_eq!(seg.segment_of(1e9), last);
    }
}
