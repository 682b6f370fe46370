//! Tube radius by circle fits on planes along the axis (reference §7f).

use glam::DVec3;
use remembrane::analysis::tube_radius::{TubeProbe, fit_circle};

#[test]
fn circle_fit_is_exact_on_a_circle_and_rejects_collinear_points() {
    let points: Vec<[f64; 2]> = (0..13)
        .map(|k| {
            let a = 0.3 + k as f64 * 0.41;
            [2.0 + 1.7 * a.cos(), -1.0 + 1.7 * a.sin()]
        })
        .collect();
    let (c, r) = fit_circle(&points).unwrap();
    assert!((r - 1.7).abs() < 1e-9, "r = {r}");
    assert!((c[0] - 2.0).abs() < 1e-9 && (c[1] + 1.0).abs() < 1e-9);
    let line: Vec<[f64; 2]> = (0..12).map(|k| [k as f64, 2.0 * k as f64]).collect();
    assert!(fit_circle(&line).is_none());
    assert!(fit_circle(&points[..2]).is_none());
}

/// A triangulated open cylinder of `radius` around the axis through `base`
/// along unit `axis`: `sides` vertices per ring, rings `spacing` apart,
/// consecutive rings twisted by half a side (as a remeshed tube is).
fn cylinder(
    base: DVec3,
    axis: DVec3,
    radius: f64,
    length: f64,
    sides: usize,
    spacing: f64,
) -> (Vec<DVec3>, Vec<[u32; 2]>) {
    let (u, v) = axis.any_orthonormal_pair();
    let rings = (length / spacing) as usize + 1;
    let mut positions = Vec::new();
    for i in 0..rings {
        for k in 0..sides {
            let a = (k as f64 + 0.5 * (i % 2) as f64) * std::f64::consts::TAU / sides as f64;
            positions
                .push(base + axis * (i as f64 * spacing) + radius * (a.cos() * u + a.sin() * v));
        }
    }
    let id = |i: usize, k: usize| (i * sides + k % sides) as u32;
    let mut edges = Vec::new();
    for i in 0..rings {
        for k in 0..sides {
            edges.push([id(i, k), id(i, k + 1)]);
            if i + 1 < rings {
                edges.push([id(i, k), id(i + 1, k)]);
                // Diagonal to the next ring's neighbour (the twist's side).
                let other = if i % 2 == 0 { k + sides - 1 } else { k + 1 };
                edges.push([id(i, k), id(i + 1, other)]);
            }
        }
    }
    (positions, edges)
}

#[test]
fn probe_recovers_the_radius_of_a_synthetic_tether_to_one_percent() {
    // A tether along (−1, 1, 0)/√2 as in the tether scene's left tube,
    // radius 1.3 l̄, 40 sides, rings 0.4 l̄ apart, planes as the reference:
    // through (−(5 + 0.5 i), 5 + 0.5 i, 0), i = 5…29, normal along the axis.
    let axis = DVec3::new(-1.0, 1.0, 0.0).normalize();
    let radius = 1.3;
    let (positions, edges) = cylinder(DVec3::new(-3.0, 3.0, 0.0), axis, radius, 25.0, 40, 0.4);
    let probe = TubeProbe {
        name: "left".into(),
        first: (-7.5, 7.5, 0.0),
        step: (-0.5, 0.5, 0.0),
        planes: 25,
        window: 5.0,
        min_points: 11,
    };
    probe.check().unwrap();
    let (r, fitted) = probe.measure(&positions, &edges).unwrap();
    assert_eq!(fitted, 25);
    // Section points lie on chords of the 40-gon: inside the circle by at
    // most 1 − cos(π/40) = 0.3 %.
    assert!(
        (r - radius).abs() < 0.01 * radius,
        "measured {r}, true {radius}"
    );
    // Planes beyond the tube's end give no fit and do not count.
    let beyond = TubeProbe {
        first: (-30.0, 30.0, 0.0),
        ..probe.clone()
    };
    assert!(beyond.measure(&positions, &edges).is_none());
}

#[test]
fn probe_settings_are_checked() {
    let probe = TubeProbe {
        name: "t".into(),
        first: (0.0, 0.0, 0.0),
        step: (0.0, 0.0, 0.0),
        planes: 3,
        window: 5.0,
        min_points: 11,
    };
    assert_eq!(probe.check().unwrap_err().0, "step");
    let few = TubeProbe {
        step: (1.0, 0.0, 0.0),
        min_points: 2,
        ..probe
    };
    assert_eq!(few.check().unwrap_err().0, "min_points");
}
