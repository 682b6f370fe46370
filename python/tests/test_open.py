"""Open membranes through the package: generated patches, loading and
saving open meshes, boundary loops, and the open-membrane terms and
conditions set by `Scene` overrides."""

import numpy as np
import pytest

import remembrane as rm

from conftest import SCENES


def test_an_open_disc_saves_and_loads_with_its_boundary(tmp_path):
    disc = rm.disc(4.0, edge_length=1.0)
    assert len(disc.points) == 61 and np.allclose(disc.points[:, 2], 0.0)
    rim = disc.boundary_edges
    assert len(rim) == 24 and len(rm.icosphere(2).boundary_edges) == 0
    assert np.allclose(np.linalg.norm(disc.points[rim[:, 0]], axis=1), 4.0)
    rm.write_mesh(tmp_path / "disc.ply", disc)
    back = rm.read_mesh(tmp_path / "disc.ply")
    assert np.array_equal(back.faces, disc.faces) and np.array_equal(back.points, disc.points)
    # An OBJ comes back with its vertices numbered in the order the faces
    # first use them: the same surface, renumbered.
    rm.write_mesh(tmp_path / "disc.obj", disc)
    back = rm.read_mesh(tmp_path / "disc.obj")
    assert len(back.faces) == len(disc.faces) and len(back.boundary_edges) == 24
    assert np.array_equal(np.unique(back.points, axis=0), np.unique(disc.points, axis=0))
    cap = rm.spherical_cap(5.0, 60.0)
    assert np.allclose(np.linalg.norm(cap.points, axis=1), 5.0)
    with pytest.raises(ValueError, match="opening_angle"):
        rm.spherical_cap(5.0, 120.0)


def test_a_broken_open_mesh_is_not_written(tmp_path):
    disc = rm.disc(3.0)
    faces = disc.faces.copy()
    faces[0] = faces[0][::-1]  # one face flipped against its neighbours
    path = tmp_path / "bad.ply"
    with pytest.raises(ValueError, match="bad.ply"):
        rm.write_mesh(path, (disc.points, faces))
    assert not path.exists()


def test_a_pinned_patch_runs_from_an_imported_mesh(tmp_path):
    cap = rm.spherical_cap(6.0, 50.0)
    rm.write_mesh(tmp_path / "cap.ply", cap)
    mesh = rm.read_mesh(tmp_path / "cap.ply")
    scene = rm.Scene.load(SCENES / "open" / "flat_patch.ron", iterations=200)
    sim = rm.Simulation(scene.with_mesh(mesh.points, mesh.faces))
    (loop,) = sim.boundary_loops
    before = sim.positions.copy()
    sim.step(200)
    after = sim.positions
    assert np.array_equal(after[loop], before[loop])
    inside = np.setdiff1d(np.arange(len(before)), loop)
    assert np.abs(after[inside] - before[inside]).max() > 1e-3
    # The boundary conditions are a scene field like any other.
    free = scene.replace(boundary=[{"Free": {"loop": 0, "line_tension": 0.3}}])
    assert "line_tension: 0.3" in free.to_ron()
    assert "line_tension" in rm.Simulation(free).energies()
    with pytest.raises(rm.SceneError) as info:
        scene.replace(boundary=[{"Roller": {"loop": 0, "direction": [0.0, 0.0, 0.0]}}])
    assert "direction" in info.value.field
    closed = rm.Simulation(rm.Scene.load(SCENES / "sphere.ron"))
    assert closed.boundary_loops == []


def test_the_adhesion_term_is_overridden_from_python():
    scene = rm.Scene.load(SCENES / "open" / "adhesion.ron", energy__Adhesion__strength=0.05)
    assert "strength: 0.05" in scene.to_ron()
    assert "adhesion" in rm.Simulation(scene).energies()
    with pytest.raises(rm.SceneError) as info:
        scene.replace(energy__Adhesion__range=0.0)
    assert info.value.field.startswith("energy.Adhesion")
