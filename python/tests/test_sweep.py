"""sweep() and collect() call the CLI's engine code; load_run reads a sweep."""

import pytest

import remembrane as rm
from conftest import SMALL_SCENE

SWEEP = """Sweep(
    name: "kappa_scan",
    scene: "small.ron",
    repeats: 2,
    seed: 11,
    grid: [(name: "kappa", values: [Kappa(0.5), Kappa(2.0)])],
)"""


@pytest.fixture
def sweep_file(tmp_path):
    (tmp_path / "small.ron").write_text(SMALL_SCENE.replace("frames: 2", "frames: 4"))
    path = tmp_path / "kappa.ron"
    path.write_text(SWEEP)
    return path


def test_sweep_runs_resumes_and_loads(sweep_file, tmp_path):
    out = tmp_path / "out"
    report = rm.sweep(sweep_file, out, jobs=2)
    assert report == {"total": 4, "in_shard": 4, "skipped": 0, "completed": 4, "failed": [], "phases": []}
    again = rm.sweep(sweep_file, out)
    assert again["skipped"] == 4 and again["completed"] == 0
    result = rm.load_run(out)
    assert isinstance(result, rm.SweepResult)
    assert len(result.runs) == 4 and all(r is not None for _, r in result.runs)
    table = result.table()
    rows = table.to_dict("records") if hasattr(table, "to_dict") else table
    assert sorted(r["kappa"] for r in rows) == [0.5, 0.5, 2.0, 2.0]
    assert len({r["seed"] for r in rows}) == 4  # derived seeds differ
    # Bending energy scales with κ at the same (nearly spherical) shape.
    by_kappa = {r["kappa"]: r["energy_bending"] for r in rows}
    assert by_kappa[2.0] / by_kappa[0.5] == pytest.approx(4.0, rel=0.05)
    collected = rm.collect(out, x="time", y="reduced_volume", frames=4, degree=1)
    assert collected["expected"] == 4 and collected["missing"] == []


def test_sweep_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text('Sweep(name: "x", scene: "none.ron")')
    with pytest.raises(ValueError, match="none.ron"):
        rm.sweep(bad, tmp_path / "out")
