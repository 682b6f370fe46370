//! Scenes with an open membrane (issue 32): the generated disc and cap
//! build and run with the terms that are correct on open meshes, and
//! every term or option that is not is refused at build time, naming the
//! file, the field, the term and the reason; a bad open mesh file exits 2
//! with no output.

use crate::common;

use remembrane::scene::{Scene, SceneError};
use std::path::{Path, PathBuf};
use std::process::Command;

const DISC: &str = r#"Scene(
    name: "patch",
    membrane: Disc(radius: 4.0),
    energy: [
        Vin(form: Exact),
        Bending(kappa: 1.0),
        Tension(sigma: 0.1),
        Area(k: 8.0, target: OfInitial(1.0)),
        Springs(),
    ],
    control_points: [(position: (0.0, 0.0, 1.0))],
    dynamics: (iterations: 20, frames: 2),
)"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn build(text: &str) -> Result<remembrane::engine::simulation::Simulation, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "open.ron", text);
    Scene::load(&path)?.build(&path)
}

#[test]
fn generated_open_patches_build_and_run() {
    for membrane in [
        "Disc(radius: 4.0)",
        "SphericalCap(sphere_radius: 5.0, opening_angle: 60.0)",
    ] {
        let text = DISC.replace("Disc(radius: 4.0)", membrane);
        // Both bending forms run on open meshes.
        let dihedral = text.replace(
            "Bending(kappa: 1.0),",
            "Bending(kappa: 1.0, discretisation: Dihedral),",
        );
        build(&dihedral).unwrap_or_else(|e| panic!("{membrane} dihedral: {e}"));
        let mut sim = build(&text).unwrap_or_else(|e| panic!("{membrane}: {e}"));
        for _ in 0..20 {
            sim.tick().unwrap();
        }
    }
}

#[test]
fn terms_and_options_not_correct_on_open_meshes_are_refused() {
    let cases = [
        (
            DISC.replace(
                "Area(k: 8.0, target: OfInitial(1.0)),",
                "Volume(k: 4.0, target: OfInitial(1.0)),",
            ),
            "energy[3]",
            "Volume",
            "encloses no volume",
        ),
        (
            DISC.replace("Area(k: 8.0, target: OfInitial(1.0)),", "")
                .replace(
                    "    dynamics:",
                    "    constraints: (area: OfInitial(1.0)),\n    dynamics:",
                ),
            "constraints",
            "area constraint",
            "boundary",
        ),
    ];
    for (text, field, what, reason) in cases {
        let msg = match build(&text) {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e.to_string(),
        };
        assert!(
            msg.contains("open.ron")
                && msg.contains(&format!("field `{field}`"))
                && msg.contains(what)
                && msg.contains("open membrane")
                && msg.contains(reason),
            "{msg}"
        );
    }
    // Remeshing keeps the held loops through its edits.
    let remeshed = DISC.replace(
        "    dynamics:",
        "    boundary: [Pinned(loop: 0)],\n    remesh: (mode: FreeEnergy),\n    dynamics:",
    );
    build(&remeshed).unwrap();
    // A bad cap angle is a field error.
    let text = DISC.replace(
        "Disc(radius: 4.0)",
        "SphericalCap(sphere_radius: 5.0, opening_angle: 120.0)",
    );
    let msg = build(&text).err().unwrap().to_string();
    assert!(msg.contains("membrane.opening_angle"), "{msg}");
}

#[test]
fn a_bad_open_mesh_file_exits_2_naming_the_file_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    // Two discs whose rims touch at one vertex.
    let mut a = remembrane::mesh::disc(2.0, 1.0);
    let b = remembrane::mesh::disc(2.0, 1.0);
    let rim = (0..a.positions.len())
        .max_by(|&i, &j| a.positions[i].x.total_cmp(&a.positions[j].x))
        .unwrap() as u32;
    let other = (0..b.positions.len())
        .min_by(|&i, &j| b.positions[i].x.total_cmp(&b.positions[j].x))
        .unwrap() as u32;
    let shift = a.positions[rim as usize] - b.positions[other as usize];
    let off = a.positions.len() as u32;
    a.positions.extend(b.positions.iter().map(|&p| p + shift));
    a.faces.extend(
        b.faces
            .iter()
            .map(|f| f.map(|v| if v == other { rim } else { v + off })),
    );
    // b's touching vertex is now unused: put the last vertex in its place.
    let unused = (other + off) as usize;
    let last = a.positions.len() - 1;
    a.positions.swap(unused, last);
    a.positions.pop();
    for f in &mut a.faces {
        for v in f.iter_mut() {
            if *v as usize == last {
                *v = unused as u32;
            }
        }
    }
    let mesh_path = dir.path().join("touching.ply");
    remembrane::mesh::io::write_mesh(&mesh_path, &a).unwrap();
    let scene = write(
        dir.path(),
        "s.ron",
        &DISC.replace("Disc(radius: 4.0)", "File(path: \"touching.ply\")"),
    );
    let out_dir = dir.path().join("out");
    let out = Command::new(env!("CARGO_BIN_EXE_remembrane"))
        .args(["run", scene.to_str().unwrap(), "--out"])
        .arg(&out_dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("s.ron")
            && err.contains("field `membrane`")
            && err.contains("touching.ply")
            && err.contains("not manifold"),
        "{err}"
    );
    assert!(!out_dir.exists(), "no partial output");
}

/// The positions of boundary loop 0 and the rest, by dense slot.
fn rim_and_interior(sim: &remembrane::engine::simulation::Simulation) -> (Vec<u32>, Vec<u32>) {
    let t = sim.membrane().cached_topology().clone();
    let rim = t.boundary_loops()[0].clone();
    let inner = (0..t.vertex_count() as u32)
        .filter(|v| !rim.contains(v))
        .collect();
    (rim, inner)
}

#[test]
fn a_pinned_rim_stays_put_under_noise_and_the_minimiser() {
    let noisy = DISC
        .replace(
            "dynamics: (iterations: 20, frames: 2)",
            "dynamics: (iterations: 200, frames: 2, temperature: 0.05)",
        )
        .replace(
            "    dynamics:",
            "    boundary: [Pinned(loop: 0)],\n    dynamics:",
        );
    let path = crate::common::repo("scenes/open/flat_patch.ron");
    let bundled = std::fs::read_to_string(&path).unwrap();
    for (text, ticks) in [(noisy, 200), (bundled, 20000)] {
        let mut sim = build(&text).unwrap();
        let positions = |sim: &remembrane::engine::simulation::Simulation| {
            let mut p = Vec::new();
            sim.membrane().gather_positions(&mut p);
            p
        };
        let before = positions(&sim);
        let (rim, inner) = rim_and_interior(&sim);
        for _ in 0..ticks {
            if sim
                .resource::<remembrane::engine::simulation::StopRequest>()
                .0
                .is_some()
            {
                break;
            }
            sim.tick().unwrap();
        }
        let after = positions(&sim);
        for &v in &rim {
            assert_eq!(
                after[v as usize], before[v as usize],
                "rim vertex {v} moved"
            );
        }
        let moved = inner
            .iter()
            .map(|&v| after[v as usize].distance(before[v as usize]))
            .fold(0.0, f64::max);
        assert!(moved > 1e-2, "the interior did not move ({moved})");
    }
}

#[test]
fn boundary_conditions_name_a_loop_that_exists() {
    let with = |membrane: &str, boundary: &str| {
        DISC.replace("Disc(radius: 4.0)", membrane).replace(
            "    dynamics:",
            &format!("    boundary: {boundary},\n    dynamics:"),
        )
    };
    for (text, reason) in [
        (
            with("Disc(radius: 4.0)", "[Pinned(loop: 1)]"),
            "1 boundary loops (0..=0), not loop 1",
        ),
        (
            with("Disc(radius: 4.0)", "[Pinned(loop: 0), Pinned(loop: 0)]"),
            "already has a condition",
        ),
        (with("Icosphere(level: 1)", "[Pinned(loop: 0)]"), "closed"),
    ] {
        let msg = match build(&text) {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e.to_string(),
        };
        assert!(
            msg.contains("open.ron") && msg.contains("field `boundary`") && msg.contains(reason),
            "{msg}"
        );
    }
}

/// The length of the closed loop `vertices` at `p` (l̄).
fn loop_length(p: &[glam::DVec3], vertices: &[u32]) -> f64 {
    (0..vertices.len())
        .map(|i| p[vertices[i] as usize].distance(p[vertices[(i + 1) % vertices.len()] as usize]))
        .sum()
}

/// The line-tension term's energy in the last evaluation (Ē).
fn line_tension_energy(sim: &remembrane::engine::simulation::Simulation) -> f64 {
    let buffers = sim.resource::<remembrane::engine::force::ForceBuffers>();
    let k = buffers
        .names()
        .iter()
        .position(|n| n == "line_tension")
        .expect("a line_tension term");
    buffers.evaluation.energies[k]
}

#[test]
fn a_free_loop_with_line_tension_adds_its_energy() {
    let text = DISC.replace(
        "    dynamics:",
        "    boundary: [Free(loop: 0, line_tension: 0.2)],\n    dynamics:",
    );
    let mut sim = build(&text).unwrap();
    let (rim, _) = rim_and_interior(&sim);
    // The tick's energies are those of the positions before its step.
    let mut p = Vec::new();
    sim.membrane().gather_positions(&mut p);
    sim.tick().unwrap();
    let length = loop_length(&p, &rim);
    let e = line_tension_energy(&sim);
    assert!(
        (e - 0.2 * length).abs() < 1e-9 * e,
        "{e} vs {}",
        0.2 * length
    );
    // A negative line tension is a field error.
    let bad = text.replace("line_tension: 0.2", "line_tension: -1.0");
    let msg = build(&bad).err().unwrap().to_string();
    assert!(
        msg.contains("boundary[0]") && msg.contains("line_tension"),
        "{msg}"
    );
}

#[test]
fn a_roller_rim_keeps_its_height_and_slides_in_its_plane() {
    // Under tension the disc shrinks: a rim held only along z slides
    // inward in its plane, while the tip lifts the interior out of it.
    for dynamics in [
        "dynamics: (iterations: 300, frames: 2, temperature: 0.05)",
        "dynamics: (method: Minimise(force_tolerance: 1e-4), iterations: 300, frames: 2)",
    ] {
        let text = DISC
            .replace("dynamics: (iterations: 20, frames: 2)", dynamics)
            .replace("Area(k: 8.0, target: OfInitial(1.0)),", "")
            .replace(
                "    dynamics:",
                "    boundary: [Roller(loop: 0, direction: (0.0, 0.0, 2.0))],\n    dynamics:",
            );
        let mut sim = build(&text).unwrap_or_else(|e| panic!("{dynamics}: {e}"));
        let mut before = Vec::new();
        sim.membrane().gather_positions(&mut before);
        let (rim, inner) = rim_and_interior(&sim);
        for _ in 0..300 {
            sim.tick().unwrap();
        }
        let mut after = Vec::new();
        sim.membrane().gather_positions(&mut after);
        let mut slid = 0.0f64;
        for &v in &rim {
            let (a, b) = (after[v as usize], before[v as usize]);
            assert_eq!(a.z, b.z, "{dynamics}: rim vertex {v} left its plane");
            slid = slid.max(a.truncate().distance(b.truncate()));
        }
        assert!(slid > 1e-3, "{dynamics}: the rim did not slide ({slid})");
        let lifted = inner
            .iter()
            .map(|&v| after[v as usize].z)
            .fold(0.0, f64::max);
        assert!(
            lifted > 1e-2,
            "{dynamics}: the interior did not lift ({lifted})"
        );
    }
    // A roller needs a direction.
    let bad = DISC.replace(
        "    dynamics:",
        "    boundary: [Roller(loop: 0, direction: (0.0, 0.0, 0.0))],\n    dynamics:",
    );
    let msg = build(&bad).err().unwrap().to_string();
    assert!(
        msg.contains("boundary") && msg.contains("direction") && msg.contains("non-zero"),
        "{msg}"
    );
}

#[test]
fn an_open_membrane_reports_no_enclosed_volume() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.ron", DISC);
    let out_dir = dir.path().join("out");
    common::run_binary(&scene, &out_dir);
    let last = crate::common::summary(&out_dir).last;
    assert!(last.area > 40.0, "{last:?}");
    assert!(
        last.volume.is_none() && last.reduced_volume.is_none(),
        "{last:?}"
    );
    let series = std::fs::read_to_string(out_dir.join("series.csv")).unwrap();
    let header = series.lines().next().unwrap();
    assert!(
        header.contains(",area,") && !header.contains("volume"),
        "{header}"
    );
}

#[test]
fn an_inflated_patch_closed_by_its_base_plane_obeys_laplace() {
    use remembrane::energy::penalty::volume_above_plane;
    let path = crate::common::repo("scenes/open/inflated_patch.ron");
    let mut sim = Scene::load(&path).unwrap().build(&path).unwrap();
    for _ in 0..20000 {
        if sim
            .resource::<remembrane::engine::simulation::StopRequest>()
            .0
            .is_some()
        {
            break;
        }
        sim.tick().unwrap();
    }
    let mut p = Vec::new();
    sim.membrane().gather_positions(&mut p);
    let t = sim.membrane().cached_topology().clone();
    let (k, target, sigma) = (20.0, 938.29, 0.5);
    let v = volume_above_plane(&p, &t.faces, glam::DVec3::ZERO, glam::DVec3::Z);
    let pressure = 2.0 * k * (target - v) / target;
    // The cap's radius: a least-squares sphere |x − c|² = R² through the
    // vertices more than 3 l̄ from the rim, |x|² = 2c·x + d.
    let inner: Vec<glam::DVec3> = p
        .iter()
        .copied()
        .filter(|x| x.truncate().length() < 9.0)
        .collect();
    let (mut m, mut rhs) = (glam::DMat4::ZERO, glam::DVec4::ZERO);
    for x in &inner {
        let row = glam::DVec4::new(2.0 * x.x, 2.0 * x.y, 2.0 * x.z, 1.0);
        m += glam::DMat4::from_cols(row * row.x, row * row.y, row * row.z, row * row.w);
        rhs += row * x.length_squared();
    }
    let s = m.inverse() * rhs;
    let c = s.truncate();
    let r = (s.w + c.length_squared()).sqrt();
    let off = inner
        .iter()
        .map(|x| (x.distance(c) - r).abs())
        .fold(0.0, f64::max);
    let laplace = 2.0 * sigma / r;
    println!("R = {r:.3} l̄ (sphere fit within {off:.1e}), p = {pressure:.5}, 2σ/R = {laplace:.5}");
    assert!(off < 0.02 * r, "not a spherical cap: {off}");
    assert!((4.0..4.5).contains(&p.iter().map(|x| x.z).fold(0.0, f64::max)));
    assert!(
        (pressure / laplace - 1.0).abs() < 0.02,
        "p = {pressure} vs 2σ/R = {laplace}"
    );
}

#[test]
fn a_closing_plane_needs_a_positive_target_and_a_normal() {
    let with = |volume: &str| DISC.replace("Springs(),", &format!("Springs(),\n        {volume},"));
    let plane = "closing: Plane(point: (0.0, 0.0, 0.0), normal: (0.0, 0.0, 1.0))";
    // The flat disc lies in its closing plane: no volume to hold a fraction of.
    for (text, field, reason) in [
        (
            with(&format!("Volume(k: 1.0, target: OfInitial(0.9), {plane})")),
            "target",
            "must be positive",
        ),
        (
            with(
                "Volume(k: 1.0, target: Absolute(10.0), closing: Plane(point: (0.0, 0.0, 0.0), normal: (0.0, 0.0, 0.0)))",
            ),
            "closing",
            "non-zero normal",
        ),
        (
            with("Volume(k: 1.0, target: Absolute(10.0))"),
            "energy",
            "declare a closing plane",
        ),
    ] {
        let msg = match build(&text) {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e.to_string(),
        };
        assert!(msg.contains(field) && msg.contains(reason), "{msg}");
    }
    build(&with(&format!(
        "Volume(k: 1.0, target: Absolute(10.0), {plane})"
    )))
    .unwrap();
}

/// Two discs side by side (two loops), a line tension on the second one
/// only, remeshed while a tension shrinks both: the edits renumber the
/// loops (by lowest vertex slot), and the line tension follows its loop by
/// the loop's vertices, so its energy stays λ times the second disc's rim.
#[test]
fn a_line_tension_follows_its_loop_through_remeshing_on_several_loops() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = remembrane::mesh::disc(4.0, 1.0);
    let other = remembrane::mesh::disc(4.0, 1.0);
    let n = mesh.positions.len() as u32;
    let shift = glam::DVec3::new(20.0, 0.0, 0.0);
    mesh.positions
        .extend(other.positions.iter().map(|&p| p + shift));
    mesh.faces
        .extend(other.faces.iter().map(|f| f.map(|v| v + n)));
    remembrane::mesh::io::write_mesh(&dir.path().join("two.ply"), &mesh).unwrap();
    let text = DISC
        .replace("Disc(radius: 4.0)", "File(path: \"two.ply\")")
        .replace("Tension(sigma: 0.1),", "Tension(sigma: 2.0),")
        .replace("Area(k: 8.0, target: OfInitial(1.0)),", "")
        .replace("dynamics: (iterations: 20, frames: 2)", "dynamics: (iterations: 3000)")
        .replace(
            "    dynamics:",
            "    boundary: [Free(loop: 1, line_tension: 0.1)],\n    remesh: (mode: FreeEnergy),\n    dynamics:",
        );
    let path = write(dir.path(), "two.ron", &text);
    let mut sim = Scene::load(&path).unwrap().build(&path).unwrap();
    let mut renumbered = false;
    for _ in 0..3000 {
        // The tick's energies are those of the positions before its step.
        let mut p = Vec::new();
        sim.membrane().gather_positions(&mut p);
        let t = sim.membrane().cached_topology().clone();
        sim.tick().unwrap();
        let loops = t.boundary_loops();
        assert_eq!(loops.len(), 2);
        let second = loops.iter().find(|l| p[l[0] as usize].x > 10.0).unwrap();
        renumbered |= p[loops[1][0] as usize].x < 10.0;
        let length = loop_length(&p, second);
        let e = line_tension_energy(&sim);
        assert!(
            (e - 0.1 * length).abs() < 1e-9 * e,
            "{e} vs {}",
            0.1 * length
        );
    }
    let stats = sim.resource::<remembrane::remesh::RemeshStats>();
    eprintln!(
        "merges {} splits {} renumbered {renumbered}",
        stats.merge.success, stats.split.success
    );
    assert!(renumbered, "the edits never renumbered the loops");
}

#[test]
fn edge_flips_fluctuate_an_open_patch_and_never_touch_its_rim() {
    let text = DISC
        .replace(
            "dynamics: (iterations: 20, frames: 2)",
            "dynamics: (iterations: 400, frames: 2, temperature: 0.1)",
        )
        .replace(
            "    dynamics:",
            "    boundary: [Pinned(loop: 0)],\n    edge_flips: (attempts_per_edge: 0.05, edge_range: (0.5, 2.0)),\n    dynamics:",
        );
    let mut sim = build(&text).unwrap();
    let mut before = Vec::new();
    sim.membrane().gather_positions(&mut before);
    let (rim, _) = rim_and_interior(&sim);
    let rim_edges = |sim: &remembrane::engine::simulation::Simulation| {
        let t = sim.membrane().cached_topology().clone();
        let mut e: Vec<[u32; 2]> = (0..t.edges.len())
            .filter(|&e| t.is_boundary_edge(e))
            .map(|e| t.edges[e])
            .collect();
        e.sort();
        e
    };
    let edges_before = rim_edges(&sim);
    for _ in 0..400 {
        sim.tick().unwrap();
    }
    let stats = *sim.resource::<remembrane::engine::shared_resources::FlipStats>();
    println!("{stats:?}");
    assert!(stats.accepted > 10, "{stats:?}");
    let t = sim.membrane().cached_topology().clone();
    let mut p = Vec::new();
    sim.membrane().gather_positions(&mut p);
    remembrane::mesh::check_mesh(&p, &t.faces, None).unwrap();
    assert_eq!(rim_edges(&sim), edges_before, "the rim's edges changed");
    for &v in &rim {
        assert_eq!(p[v as usize], before[v as usize]);
    }
}
