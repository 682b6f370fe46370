//! Where the species live: each species' protein amount per vertex is a
//! component of the vertex entities ([`ProteinAmount`]), an amount carried
//! through splits, merges and flips with its density per vertex area kept
//! (its field transfer is [`TransferPolicy::Density`]), so every count
//! Σ_i n_i is exact through remeshing and a smooth field stays smooth.
//! The fractions are derived: φ_s,i = a_s n_s,i / A_i with the mixed
//! Voronoi area A_i at the current shape.
//!
//! The dense mirror [`SpeciesAmounts`] (by species, then dense vertex slot)
//! is published for the force terms ([`crate::engine::term_inputs`]) and
//! refreshed from the world each tick.

use crate::energy::bending::BendingDiscretisation;
use crate::energy::bending_measure::vertex_areas;
use crate::mesh::membrane::{Membrane, gather_field};
use crate::mesh::topology::{Topology, TopologyError};
use crate::mesh::vertex_field::{ScalarComponent, TransferPolicy};
use crate::species::params::{MAX_SPECIES, SpeciesSet};
use glam::DVec3;
use hecs::World;

/// The protein amount (number of proteins) of the `K`-th declared species
/// at a vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProteinAmount<const K: usize>(pub f64);

impl<const K: usize> ScalarComponent for ProteinAmount<K> {
    fn value(&self) -> f64 {
        self.0
    }
    fn from_value(value: f64) -> Self {
        Self(value)
    }
}

/// Calls `$body` with `$C` the component type of species `$k`
/// (`ProteinAmount<0>` … `ProteinAmount<7>`).
macro_rules! with_component {
    ($k:expr, $C:ident => $body:expr) => {
        with_component!(@arms $k, $C => $body; 0 1 2 3 4 5 6 7)
    };
    (@arms $k:expr, $C:ident => $body:expr; $($n:literal)*) => {
        match $k {
            $($n => {
                type $C = ProteinAmount<$n>;
                $body
            })*
            _ => unreachable!("at most {MAX_SPECIES} species (validated)"),
        }
    };
}

/// The name of species `name`'s per-vertex field (its amounts).
pub fn field_name(name: &str) -> String {
    format!("amount_{name}")
}

/// Adds the amounts of every species of `set` to the vertices of
/// `membrane`, `initial(k, slot, position)` proteins of species k at each,
/// and registers their conservative transfer.
pub fn add_amounts(
    membrane: &mut Membrane,
    set: &SpeciesSet,
    initial: impl Fn(usize, usize, DVec3) -> f64,
) -> Result<(), TopologyError> {
    for (k, s) in set.species.iter().enumerate() {
        let name = field_name(&s.name);
        let values = |slot: usize, p: DVec3| initial(k, slot, p);
        with_component!(k, C => membrane.add_vertex_field::<C>(&name, TransferPolicy::Density, values))?;
    }
    Ok(())
}

/// Species `k`'s amounts from the world, by dense slot of `topology`, into
/// `out` (0 at a vertex without the component).
pub fn read_amounts(world: &World, topology: &Topology, k: usize, out: &mut Vec<f64>) {
    with_component!(k, C => gather_field::<C>(world, topology, out));
}

/// Writes species `k`'s amounts `values` (by dense slot of the cached
/// topology) into the world's components.
pub fn write_amounts(membrane: &mut Membrane, k: usize, values: &[f64]) {
    with_component!(k, C => membrane.scatter_vertex_field::<C>(values));
}

/// Why fractions could not be set.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FractionsError {
    /// Not one value per vertex.
    #[error("{given} values for {vertices} vertices")]
    Length {
        /// Values given.
        given: usize,
        /// Vertices of the membrane.
        vertices: usize,
    },
    /// A value outside (0, 1), or the species' sum at 1 or more.
    #[error(
        "φ = {value} at vertex {vertex} is outside (0, 1) or brings the species' sum to 1 or more"
    )]
    Outside {
        /// The dense vertex slot.
        vertex: usize,
        /// The value given.
        value: f64,
    },
}

/// Sets species `k`'s fractions to `phi` (by dense slot) at the current
/// shape of `membrane`: its amounts become A_i φ_i / a_k at the vertex
/// areas in `form`. Returns the species' new count (proteins). Nothing is
/// written if a value is outside (0, 1) or brings the species' sum to 1.
pub fn write_fractions(
    membrane: &mut Membrane,
    set: &SpeciesSet,
    form: BendingDiscretisation,
    k: usize,
    phi: &[f64],
) -> Result<f64, FractionsError> {
    let t = membrane
        .topology()
        .expect("a membrane with species has a valid topology")
        .clone();
    let mut positions = Vec::new();
    membrane.gather_positions(&mut positions);
    let n = positions.len();
    if phi.len() != n {
        return Err(FractionsError::Length {
            given: phi.len(),
            vertices: n,
        });
    }
    let mut dense = SpeciesAmounts::default();
    dense.gather(&membrane.world, &t, set.species.len());
    let mut geometry = Vec::new();
    crate::mesh::geometry::face_geometry(&positions, &t.faces, &mut geometry);
    let areas = vertex_areas(&t.faces, &geometry, n, form);
    let current = fractions(set, &dense.0, &areas);
    for (i, &x) in phi.iter().enumerate() {
        let others: f64 = (0..current.len())
            .filter(|&s| s != k)
            .map(|s| current[s][i])
            .sum();
        if !(x > 0.0 && x + others < 1.0) {
            return Err(FractionsError::Outside {
                vertex: i,
                value: x,
            });
        }
    }
    let a = set.species[k].area_per_protein;
    let values: Vec<f64> = phi
        .iter()
        .zip(&areas)
        .map(|(p, area)| area * p / a)
        .collect();
    write_amounts(membrane, k, &values);
    Ok(values.iter().sum())
}

/// The dense amounts of every species (proteins; by species, then dense
/// vertex slot), as the force terms read them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpeciesAmounts(pub Vec<Vec<f64>>);

impl SpeciesAmounts {
    /// Reads every one of `species` species' amounts from the world.
    pub fn gather(&mut self, world: &World, topology: &Topology, species: usize) {
        self.0.resize(species, Vec::new());
        for (k, out) in self.0.iter_mut().enumerate() {
            read_amounts(world, topology, k, out);
        }
    }

    /// Each species' protein count Σ_i n_i.
    pub fn counts(&self) -> Vec<f64> {
        self.0.iter().map(|n| n.iter().sum()).collect()
    }
}

/// The fractions φ_s,i = a_s n_s,i / A_i of the amounts `amounts` on the
/// vertex areas `areas`.
pub fn fractions(set: &SpeciesSet, amounts: &[Vec<f64>], areas: &[f64]) -> Vec<Vec<f64>> {
    set.species
        .iter()
        .zip(amounts)
        .map(|(s, n)| {
            n.iter()
                .zip(areas)
                .map(|(n, a)| s.area_per_protein * n / a)
                .collect()
        })
        .collect()
}

/// The fractions of the amounts `amounts` on the mesh of `faces` at
/// `positions` (its vertex areas in `form` measured here).
pub fn fractions_at(
    set: &SpeciesSet,
    amounts: &[Vec<f64>],
    positions: &[DVec3],
    faces: &[[u32; 3]],
    form: BendingDiscretisation,
) -> Vec<Vec<f64>> {
    let mut geometry = Vec::new();
    crate::mesh::geometry::face_geometry(positions, faces, &mut geometry);
    let areas = vertex_areas(faces, &geometry, positions.len(), form);
    fractions(set, amounts, &areas)
}

/// The amounts n_s,i = A_i φ_s,i / a_s of the fractions `phi`.
pub fn amounts(set: &SpeciesSet, phi: &[Vec<f64>], areas: &[f64]) -> Vec<Vec<f64>> {
    set.species
        .iter()
        .zip(phi)
        .map(|(s, p)| {
            p.iter()
                .zip(areas)
                .map(|(p, a)| a * p / s.area_per_protein)
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::icosphere;
    use crate::species::params::Species;

    #[test]
    fn each_species_amounts_are_a_vertex_field_read_and_written_densely() {
        let set = SpeciesSet {
            species: ["a", "b", "c"]
                .iter()
                .map(|n| Species::new(n, 0.1, crate::species::params::Initial::Fraction(0.1)))
                .collect(),
            interactions: vec![],
            temperature: 0.1,
        };
        let mut m = Membrane::from_mesh(&icosphere(2, 1.0), false).unwrap();
        add_amounts(&mut m, &set, |k, slot, _| {
            (k + 1) as f64 + 0.01 * slot as f64
        })
        .unwrap();
        let names: Vec<&str> = m.fields().iter().map(|f| f.name()).collect();
        assert_eq!(names, ["amount_a", "amount_b", "amount_c"]);
        let mut dense = SpeciesAmounts::default();
        m.topology().unwrap();
        dense.gather(&m.world, m.cached_topology(), 3);
        let before = dense.counts();
        assert_eq!(dense.0[2][5], 3.05);
        // Species 1 written back doubled, the others untouched.
        let doubled: Vec<f64> = dense.0[1].iter().map(|x| 2.0 * x).collect();
        write_amounts(&mut m, 1, &doubled);
        dense.gather(&m.world, m.cached_topology(), 3);
        assert_eq!(dense.0[1], doubled);
        assert_eq!(dense.counts()[0], before[0]);
        assert_eq!(dense.counts()[2], before[2]);
    }
}
