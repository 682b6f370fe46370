"""meshio interop (meshio is optional; CI installs it)."""

import numpy as np
import pytest

import remembrane as rm
from conftest import SMALL_SCENE

meshio = pytest.importorskip("meshio")


def test_to_and_from_meshio_round_trip(tmp_path):
    sim = rm.Simulation(rm.Scene.from_str(SMALL_SCENE))
    m = rm.to_meshio(sim)
    assert isinstance(m, meshio.Mesh)
    np.testing.assert_array_equal(m.points, sim.positions)
    np.testing.assert_array_equal(m.cells_dict["triangle"], sim.faces)
    path = tmp_path / "vesicle.vtu"
    m.write(path)
    back = rm.from_meshio(meshio.read(path))
    np.testing.assert_allclose(back.points, sim.positions)
    scene = rm.Scene.from_str(SMALL_SCENE).with_mesh(back.points, back.faces)
    assert len(rm.Simulation(scene).positions) == len(sim.positions)


def test_from_meshio_rejects_non_triangles():
    quad = meshio.Mesh(np.eye(4, 3), [("quad", np.array([[0, 1, 2, 3]]))])
    with pytest.raises(ValueError, match="triangles only"):
        rm.from_meshio(quad)
