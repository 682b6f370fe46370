"""Protein species from Python: `sim.species` reads and sets the fields."""

import numpy as np
import pytest

import remembrane as rm

SPECIES_SCENE = """Scene(
    name: "species",
    membrane: Ellipsoid(level: 2, semi_axes: (3.6, 3.6, 2.0)),
    model: Fluid(),
    energy: [
        Vin(form: Exact),
        Bending(kappa: 1.0),
    ],
    constraints: (area: OfInitial(1.0), volume: OfInitial(1.0)),
    dynamics: (
        method: Minimise(force_tolerance: 1e-3, field_tolerance: 1e-10),
        iterations: 300,
        frames: 2,
    ),
    species: (
        species: [
            (name: "bar", area_per_protein: 0.05, curvature_coupling: 4.0, initial: Fraction(0.2)),
            (name: "epsin", area_per_protein: 0.05, curvature_coupling: -2.0,
             initial: Fraction(0.1), reservoir: Bulk, chemical_potential: Some(-0.2)),
        ],
    ),
)"""


def test_species_fields_are_read_and_set_by_name():
    sim = rm.Simulation(rm.Scene.from_str(SPECIES_SCENE))
    n = len(sim.positions)
    assert sim.species.keys() == ["bar", "epsin"]
    assert list(sim.species) == ["bar", "epsin"] and len(sim.species) == 2
    assert "bar" in sim.species and "dynamin" not in sim.species
    bar = sim.species["bar"]
    assert bar.shape == (n,) and bar.dtype == np.float64
    assert np.allclose(bar, 0.2)
    with pytest.raises(KeyError, match="no species"):
        sim.species["dynamin"]
    # A conserved species set to another field: its count follows, and the
    # minimiser holds the new count while the proteins sort.
    z = sim.positions[:, 2]
    wanted = 0.25 + 0.05 * z / np.abs(z).max()
    sim.species["bar"] = wanted
    assert np.allclose(sim.species["bar"], wanted, rtol=1e-12)
    sim.step(100)
    after = sim.species["bar"]
    assert not np.allclose(after, wanted)
    assert after.min() > 0 and after.max() < 1
    with pytest.raises(ValueError, match="outside"):
        sim.species["bar"] = np.full(n, 1.2)
    with pytest.raises(ValueError, match="values for"):
        sim.species["bar"] = np.full(n - 1, 0.2)


def test_a_scene_without_species_has_none():
    sim = rm.Simulation(
        rm.Scene.from_str(
            'Scene(name: "s", membrane: Icosphere(level: 2), energy: [Bending(kappa: 1.0)])'
        )
    )
    assert sim.species.keys() == [] and len(sim.species) == 0


def test_a_field_set_from_python_relaxes_by_transport_at_the_diffusion_rate():
    # A sphere (R = 4) whose shape holds still (vertex mobility 1e-9), one
    # species with D = M k_BT / a_p = 1 l̄²/s: an l = 1 field set from
    # Python decays at 2D/R² = 0.125/s, so by e^{-0.625} = 0.535 in 5 s.
    sim = rm.Simulation(
        rm.Scene.from_str(
            """Scene(
    name: "spreading",
    membrane: Ellipsoid(level: 3, semi_axes: (4.0, 4.0, 4.0)),
    energy: [Bending(kappa: 1.0)],
    dynamics: (mobility: 1e-9, dt_max: 0.01, frames: 0),
    species: (species: [(name: "p", area_per_protein: 0.01, initial: Fraction(0.05),
                         mobility: 0.1)]),
)"""
        )
    )
    z = sim.positions[:, 2] / 4.0
    field = 0.05 + 0.001 * z
    sim.species["p"] = field
    assert np.allclose(sim.species["p"], field, rtol=1e-12)
    sim.step(500)
    after = sim.species["p"]
    amplitude = np.dot(after - after.mean(), z) / np.dot(z, z)
    assert abs(amplitude / 0.001 / np.exp(-0.625) - 1) < 0.02, amplitude
