"""Simulation.run writes the CLI's run directory, byte for byte."""

import subprocess

import numpy as np
import pytest

import remembrane as rm
from conftest import SCENES

RBC = SCENES / "red_blood_cell.ron"
ITERATIONS = 1000
# Every file of a run except summary.json, whose wall times differ.
SAME_FILES = ["final.ply", "series.csv", "state.json", "events.csv", "run.pvd"]


def cli_run(cli, out, *extra):
    subprocess.run(
        [str(cli), "run", str(RBC), "--out", str(out), "--iterations", str(ITERATIONS), "--quiet", *extra],
        check=True,
    )


@pytest.fixture(scope="module")
def cli_dir(tmp_path_factory):
    from conftest import cli_binary

    out = tmp_path_factory.mktemp("cli") / "rbc"
    cli_run(cli_binary(), out)
    return out


@pytest.mark.parametrize("threads", [None, 1, 2])
def test_rbc_run_is_byte_identical_to_the_cli(cli_dir, tmp_path, threads):
    out = tmp_path / "rbc"
    sim = rm.Simulation(rm.Scene.load(RBC, iterations=ITERATIONS), threads=threads)
    summary = sim.run(out=out, progress=False)
    assert summary["status"] == "completed"
    assert summary["iterations"] == ITERATIONS
    for name in SAME_FILES:
        assert (out / name).read_bytes() == (cli_dir / name).read_bytes(), name
    frames = sorted(p.name for p in (out / "frames").iterdir())
    assert frames == sorted(p.name for p in (cli_dir / "frames").iterdir())
    for f in frames:
        assert (out / "frames" / f).read_bytes() == (cli_dir / "frames" / f).read_bytes(), f
    assert not (tmp_path / "rbc.incomplete").exists()
    # The simulation keeps its final state for inspection.
    assert sim.iteration == ITERATIONS
    final = rm.read_mesh(out / "final.ply")
    np.testing.assert_array_equal(sim.positions, final.points)


def test_stepping_reaches_the_runs_final_state(cli_dir):
    # step() advances exactly like run(): same ticks, same positions.
    sim = rm.Simulation(rm.Scene.load(RBC, iterations=ITERATIONS))
    sim.step(ITERATIONS)
    final = rm.read_mesh(cli_dir / "final.ply")
    np.testing.assert_array_equal(sim.positions, final.points)
    np.testing.assert_array_equal(sim.faces, final.faces)


def test_load_run_reads_series_summary_and_frames(cli_dir):
    run = rm.load_run(cli_dir)
    assert run.status == "completed"
    assert run.summary["iterations"] == ITERATIONS
    series = run.series
    iterations = np.asarray(series["iteration"])
    assert iterations[0] == 0 and iterations[-1] == ITERATIONS
    v = np.asarray(series["reduced_volume"])
    assert np.all((v > 0.5) & (v <= 1.0))
    last = run.frame(-1)
    n = run.summary["vertices"]
    assert last.points.shape == (n, 3) and last.points.dtype == np.float64
    assert last.faces.shape == (run.summary["faces"], 3)
    assert last.point_data["force"].shape == (n, 3)
    assert last.point_data["mean_curvature"].shape == (n,)
    np.testing.assert_array_equal(last.points, run.final_mesh().points)
    assert len(list(run.frames())) == len(run.frame_files)


def test_load_run_names_a_renamed_or_malformed_field(cli_dir, tmp_path):
    import shutil

    for name, edit, pattern in [
        ("summary.json", lambda t: t.replace('"iterations"', '"its"', 1), "summary.json.*iterations"),
        ("series.csv", lambda t: t.replace("\n0,", "\nx,", 1), "series.csv.*iteration.*line 2"),
    ]:
        copy = tmp_path / name.replace(".", "_")
        shutil.copytree(cli_dir, copy)
        path = copy / name
        path.write_text(edit(path.read_text()))
        with pytest.raises(ValueError, match=pattern):
            rm.load_run(copy)


def test_run_refuses_an_existing_directory_and_a_stepped_simulation(tmp_path):
    scene = rm.Scene.load(RBC, iterations=10)
    (tmp_path / "taken").mkdir()
    sim = rm.Simulation(scene)
    with pytest.raises(FileExistsError, match="overwrite=True"):
        sim.run(out=tmp_path / "taken", progress=False)
    # Evaluating forces first does not spoil the run.
    sim.energies()
    assert sim.run(out=tmp_path / "ok", progress=False)["iterations"] == 10
    with pytest.raises(rm.SimulationError, match="done its run"):
        sim.step()
    stepped = rm.Simulation(scene)
    stepped.step(3)
    with pytest.raises(rm.SimulationError, match="stepped 3 iterations"):
        stepped.run(out=tmp_path / "late", progress=False)
    assert not (tmp_path / "late").exists() and not (tmp_path / "late.incomplete").exists()
