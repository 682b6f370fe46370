"""Scenes, state arrays, errors and Python force terms."""

import numpy as np
import pytest

import remembrane as rm
from conftest import SCENES, SMALL_SCENE


def small(**overrides):
    return rm.Simulation(rm.Scene.from_str(SMALL_SCENE, **overrides))


def test_state_arrays_have_numpy_shapes_and_dtypes():
    sim = small()
    n = 642 - 480  # level-2 icosphere: 162 vertices
    assert sim.positions.shape == (n, 3) and sim.positions.dtype == np.float64
    assert sim.faces.shape == (2 * n - 4, 3) and sim.faces.dtype == np.int64
    assert sim.edges.shape == (3 * n - 6, 2) and sim.edges.dtype == np.int64
    assert sim.faces.min() == 0 and sim.faces.max() == n - 1
    energies = sim.energies()
    assert list(energies) == ["bending", "area", "volume"]
    assert all(isinstance(e, float) for e in energies.values())
    total = sim.forces()
    assert total.shape == (n, 3) and total.dtype == np.float64
    for term in energies:
        assert sim.forces(term).shape == (n, 3)
    with pytest.raises(KeyError, match="no force term"):
        sim.forces("nope")
    q = sim.mesh_quality()
    assert 0 < q["edge_min"] <= q["edge_mean"] <= q["edge_max"]
    assert sum(q["valence_histogram"].values()) == n
    assert sim.remesh_stats() is None  # the scene declares no remeshing
    assert sim.flip_stats() is None  # nor edge flips
    sim.step(5)
    assert sim.iteration == 5 and sim.time > 0


def test_total_force_is_the_sum_of_the_terms_without_smoothing():
    sim = small(penalty_smoothing=0)
    total = sum(sim.forces(t) for t in sim.energies())
    np.testing.assert_allclose(sim.forces(), total, rtol=0, atol=1e-12)


def test_per_vertex_field_of_a_lipid_scene():
    sim = rm.Simulation(rm.Scene.load(SCENES / "tether_initial.ron"))
    assert "lipid_density" in sim.field_names
    rho = sim.field("lipid_density")
    assert rho.shape == (len(sim.positions),) and rho.dtype == np.float64
    np.testing.assert_array_equal(rho, 1.0)
    with pytest.raises(KeyError, match="lipid_density"):
        sim.field("protein")


def test_scene_errors_carry_file_line_field_and_reason(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text('Scene(\n    membrane: Icosphere(level: 2),\n    energy: [Bending(kappa: -1.0)],\n)\n')
    with pytest.raises(rm.SceneError) as info:
        rm.Scene.load(bad)
    e = info.value
    assert e.file == str(bad)
    assert e.line == 3
    assert e.field == "energy[0].Bending.kappa"
    assert "≥ 0" in e.reason
    assert str(e).startswith(f"{bad}:3:")
    assert isinstance(e, ValueError)
    with pytest.raises(rm.SceneError) as info:
        rm.Scene.load(tmp_path / "missing.ron")
    assert info.value.line is None and "cannot read" in str(info.value)


def test_overrides_are_validated_like_the_file():
    base = rm.Scene.load(SCENES / "red_blood_cell.ron")
    s = rm.Scene.load(SCENES / "red_blood_cell.ron", seed=7, iterations=10, dynamics__temperature=0.05)
    assert (s.seed, s.iterations) == (7, 10)
    assert "temperature: 0.05" in s.to_ron()
    assert s == base.replace(seed=7, iterations=10, set={"dynamics.temperature": 0.05})
    assert rm.Scene.from_str(s.to_ron(), s.path) == s
    with pytest.raises(rm.SceneError) as info:
        base.replace(energy__Bending__kappa=-2.0)
    assert info.value.field == "energy.Bending.kappa"
    with pytest.raises(rm.SceneError, match="no field or variant `tempeature`"):
        base.replace(dynamics__tempeature=0.1)
    # numpy scalars are numbers, kept exactly.
    x = np.linspace(0, 1, 7)[3]
    s2 = base.replace(iterations=np.int64(12), energy__Bending__kappa=np.float32(2.5), dynamics__dt_max=x)
    assert s2.iterations == 12
    assert s2 == base.replace(iterations=12, energy__Bending__kappa=2.5, dynamics__dt_max=float(x))
    assert f"dt_max: {float(x)!r}" in s2.to_ron() or repr(float(x)) in s2.to_ron()


def test_with_mesh_uses_the_given_membrane():
    mesh = rm.icosphere(2, edge_length=0.5)
    scene = rm.Scene.from_str(SMALL_SCENE).with_mesh(mesh.points, mesh.faces)
    sim = rm.Simulation(scene)
    np.testing.assert_array_equal(sim.positions, mesh.points)
    with pytest.raises(rm.SceneError, match="membrane"):
        scene.with_mesh(mesh.points, mesh.faces[:-1])  # no longer closed


# --- Python force terms -------------------------------------------------

FIELD_SCENE = """Scene(
    name: "field",
    membrane: Icosphere(level: 2, jitter: 0.02),
    energy: [Bending(kappa: 1.0)],
    penalty_smoothing: 0,
    dynamics: (mobility: 1.0, temperature: 0.0, dt_max: 1e-3, max_displacement: 0.01, iterations: 200),
)"""
FIELD = np.array([0.3, -0.2, 0.5])  # Ē/l̄ on every vertex
MOBILITY = 1.0


def uniform_field(x):
    """E = −F·Σx, so −∇E = F on every vertex."""
    return -float(x.sum(axis=0) @ FIELD), np.tile(FIELD, (len(x), 1))


def test_python_force_term_moves_the_membrane_as_predicted():
    # Bending's net force is zero (translation invariance), so the centroid
    # moves by μ F t exactly, up to rounding (~1e-13 per step).
    sim = rm.Simulation(rm.Scene.from_str(FIELD_SCENE))
    sim.add_force_term("field", uniform_field)
    start = sim.positions.mean(axis=0)
    sim.step(200)
    moved = sim.positions.mean(axis=0) - start
    np.testing.assert_allclose(moved, MOBILITY * FIELD * sim.time, rtol=0, atol=1e-9)
    assert np.linalg.norm(moved) > 1e-3  # it did move
    x = sim.positions
    assert sim.energies()["field"] == pytest.approx(-(x.sum(axis=0) @ FIELD), rel=1e-12)
    np.testing.assert_array_equal(sim.forces("field"), np.tile(FIELD, (len(x), 1)))


def test_python_term_in_a_run_is_timed_and_recorded(tmp_path):
    sim = rm.Simulation(rm.Scene.from_str(FIELD_SCENE, iterations=20, frames=2))
    sim.add_force_term("field", uniform_field)
    summary = sim.run(out=tmp_path / "run", progress=False)
    assert "field" in [e["term"] for e in summary["energies"]]
    assert "field" in [t["system"] for t in summary["timings"]]
    series = rm.load_run(tmp_path / "run").series
    assert "energy_field" in list(series.keys() if isinstance(series, dict) else series.columns)


def test_force_term_errors_reach_python():
    sim = rm.Simulation(rm.Scene.from_str(FIELD_SCENE))

    def broken(x):
        raise ArithmeticError("plate went missing")

    sim.add_force_term("broken", broken)
    with pytest.raises(ArithmeticError, match="plate went missing"):
        sim.step()
    assert sim.iteration == 0

    wrong_shape = rm.Simulation(rm.Scene.from_str(FIELD_SCENE))
    wrong_shape.add_force_term("bad", lambda x: (0.0, np.zeros((3, 3))))
    with pytest.raises(ValueError, match=r"shape \[3, 3\]; expected \(162, 3\)"):
        wrong_shape.step()

    nan = rm.Simulation(rm.Scene.from_str(FIELD_SCENE))
    nan.add_force_term("nan", lambda x: (0.0, np.full_like(x, np.nan)))
    with pytest.raises(rm.SimulationError, match="nan"):
        nan.step()

    with pytest.raises(TypeError, match="callable"):
        sim.add_force_term("x", 3)
    with pytest.raises(ValueError, match="field"):
        twice = rm.Simulation(rm.Scene.from_str(FIELD_SCENE))
        twice.add_force_term("field", uniform_field)
        twice.add_force_term("field", uniform_field)
    moved = rm.Simulation(rm.Scene.from_str(FIELD_SCENE))
    moved.step()
    with pytest.raises(rm.SimulationError, match="before the first step"):
        moved.add_force_term("late", uniform_field)


def test_a_term_calling_back_into_its_simulation_is_refused():
    sim = rm.Simulation(rm.Scene.from_str(FIELD_SCENE))
    sim.add_force_term("nosy", lambda x: (float(sim.iteration), np.zeros_like(x)))
    with pytest.raises(rm.SimulationError, match="busy"):
        sim.step()


# --- finite-difference check of a Python term -----------------------------

K = 2.5  # Ē/l̄² of the harmonic trap


def trap(x):
    return 0.5 * K * float((x * x).sum()), -K * x


def test_fd_check_passes_a_correct_term_and_fails_a_wrong_one():
    report = rm.check_force(trap, rm.perturbed_icosphere(2, seed=3))
    assert report["passed"], report
    assert report["vertices"] == 162
    assert report["max_rel_error"] < 1e-8
    # Nonlinear energy: E = Σ|x|⁴/4, F = −|x|² x.
    quartic = lambda x: (0.25 * float(((x * x).sum(axis=1) ** 2).sum()), -((x * x).sum(axis=1))[:, None] * x)
    assert rm.check_force(quartic)["passed"]
    wrong = lambda x: (0.5 * K * float((x * x).sum()), -1.01 * K * x)
    bad = rm.check_force(wrong, rm.perturbed_icosphere(2, seed=3))
    assert not bad["passed"]
    assert len(bad["failures"]) == 162
    vertex, analytic, numeric = bad["failures"][0]
    np.testing.assert_allclose(np.array(analytic) / np.array(numeric), 1.01, rtol=1e-6)
    only = rm.check_force(wrong, rm.perturbed_icosphere(), vertices=[0, 5])
    assert only["vertices"] == 2 and len(only["failures"]) == 2
    sim = rm.Simulation(rm.Scene.from_str(SMALL_SCENE))
    assert rm.check_force(trap, sim)["passed"]  # on a simulation's current mesh


def test_flip_stats_of_a_fluid_vesicle():
    sim = rm.Simulation(rm.Scene.load(SCENES / "fluctuating" / "flips.ron"))
    sim.step(200)
    stats = sim.flip_stats()
    assert stats["accepted"] > 0
    assert stats["proposed"] == sum(
        stats[k]
        for k in ("accepted", "rejected_topology", "rejected_geometry", "rejected_energy")
    )


def test_a_wall_is_declared_overridden_and_recorded(tmp_path):
    scene = rm.Scene.load(SCENES / "open" / "confined.ron", energy__Wall__strength=2.0, iterations=50)
    assert "strength: 2.0" in scene.to_ron()
    sim = rm.Simulation(scene)
    assert "wall" in sim.energies() and sim.energies()["wall"] == 0.0  # the capsule starts out of range
    summary = sim.run(out=tmp_path / "confined", progress=False)
    assert summary["status"] == "completed"
    run = rm.load_run(tmp_path / "confined")
    assert (run.series["wall_min_distance"] > 0).all()
    with pytest.raises(rm.SceneError) as info:
        scene.replace(energy__Wall__range=-1.0)
    assert info.value.field == "energy.Wall.range"
