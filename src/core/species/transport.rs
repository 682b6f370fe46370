//! The species' fields in overdamped dynamics: transport along the
//! membrane and binding from a bulk over one tick of a fixed shape.
//!
//! Each species s moves down its chemical potential μ_s,i = ∂F/∂n_s,i (Ē
//! per protein, F the species' free energy of
//! [`crate::species::free_energy`] at the amounts n):
//!
//! - **transport** (mobility M_s > 0): over every edge e = (i, j),
//!   dn_i/dt = k_e (μ_j − μ_i) with k_e = w_e M_s m_s(φ̄_e) / a_s², w_e the
//!   cotangent weight ½(cot α + cot β) (taken as 0 where negative, which
//!   a Delaunay mesh never is), m_s = φ_s (1 − Σ_t φ_t) at the mean of the
//!   two ends, the discrete ∂φ/∂t = ∇·(M φ(1 − φ) ∇δF/δφ). Each flux
//!   leaves one vertex and enters the other, so every count is conserved to
//!   round-off;
//! - **binding** (a bulk species with rate Γ_s > 0): dn_i/dt = −g_i (μ_i −
//!   μ_bulk), g_i = A_i Γ_s m_s(φ_i) / (k_BT a_s), so a dilute coverage
//!   relaxes to the bulk's at rate Γ_s.
//!
//! At temperature (the dynamics' k_BT > 0, which must be the species'),
//! each edge and each binding vertex adds the noise of fluctuation-
//! dissipation, √(2 k_BT k h) per step h, with the mobility's drift
//! k_BT ∂k/∂n (the fields' mobility depends on them). The steps follow
//! Leimkuhler and Matthews (2013): the noise of step n is the mean of two
//! consecutive draws, (ξ_n + ξ_{n+1})/2, which gives a linear(ised) field
//! its exact equilibrium variance at any stable step (the Euler-Maruyama
//! step's is too large by 1/(1 − λh/2)). The draws come from a stream
//! seeded by (seed, step count), so a run is reproducible from its seed,
//! and a checkpoint that keeps the count resumes it exactly.
//!
//! The steps are explicit: a tick of length Δt is cut into steps of at
//! most [`STABLE_FRACTION`] of 1/λ, λ a Gershgorin bound of the fastest
//! rate (the mobility times the local Hessian ∂μ/∂n). A step that takes a
//! field out of φ > 0, Σφ < 1 is halved, its draws kept.

use crate::energy::bending_measure::{Surface, VertexTerms};
use crate::species::free_energy::{BaseBending, LocalEnergy};
use crate::species::measured::{Block, HessianConstants, MeasuredVertices};
use crate::species::params::{MAX_SPECIES, Reservoir, SpeciesSet};
use crate::util::rng::stream_seed;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// The fraction of the fastest rate's inverse (its Gershgorin bound) a
/// step takes: λh ≤ ½ keeps every mode stable and decaying (explicit
/// Euler is stable to λh < 2) and the smooth ones accurate.
pub const STABLE_FRACTION: f64 = 0.5;

/// Halvings of a step that leaves the fields' domain before the transport
/// gives up.
const MOST_HALVINGS: u32 = 40;

/// Stream id of the fields' thermal noise.
const NOISE_STREAM: u64 = 0x7370_6563_6965_7301;

/// The thermal noise of a tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Noise {
    /// The run's seed.
    pub seed: u64,
    /// Steps taken before this tick over the run (the draws' counter).
    pub steps: u64,
}

/// What a tick of transport did.
#[derive(Clone, Debug, PartialEq)]
pub struct Transported {
    /// Steps taken.
    pub steps: u64,
    /// Each species' chemical potential (Ē per protein): a bulk species'
    /// given μ, a conserved species' mean of μ_i over the area at the end
    /// (uniform at equilibrium).
    pub chemical_potentials: Vec<f64>,
}

/// Why the transport stopped.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TransportError {
    /// A field is outside φ > 0, Σφ < 1, at the start of the tick (the
    /// shape's step squeezed a vertex's area under its proteins) or after
    /// a step halved 40 times.
    #[error(
        "species {species}: φ = {value} at vertex {vertex} is outside (0, 1) or the fractions \
         sum to 1 or more {when}"
    )]
    Outside {
        /// The species' index.
        species: usize,
        /// The dense vertex slot.
        vertex: usize,
        /// The value found.
        value: f64,
        /// When it was found.
        when: &'static str,
    },
}

/// The reusable buffers of the transport.
#[derive(Default)]
pub struct Transport {
    /// The measure of the shape of the last advance.
    terms: VertexTerms,
    phi: Vec<Vec<f64>>,
    grad: Vec<Vec<f64>>,
    mu: Vec<Vec<f64>>,
    stiffness: Vec<Vec<f64>>,
    change: Vec<Vec<f64>>,
    trial: Vec<Vec<f64>>,
    weights: Vec<f64>,
    rate: Vec<f64>,
    /// Draws of the current and the next step, by species: its edges',
    /// then (a binding species) its vertices'.
    draws: [Vec<Vec<f64>>; 2],
}

impl Transport {
    /// The measure of the shape of the last [`Transport::advance`] (given
    /// up to the caller, who may publish it for the terms evaluated next at
    /// the same positions; the next advance measures again).
    pub fn measure_mut(&mut self) -> &mut VertexTerms {
        &mut self.terms
    }

    /// Advances the `amounts` (proteins, by species then dense slot) on
    /// the fixed `shape` by `dt` (s), with `noise` at temperature.
    pub fn advance(
        &mut self,
        shape: Surface<'_>,
        base: BaseBending,
        set: &SpeciesSet,
        amounts: &mut [Vec<f64>],
        dt: f64,
        noise: Option<Noise>,
    ) -> Result<Transported, TransportError> {
        let ns = set.species.len();
        let n = shape.vertex_count();
        self.terms.measure(shape, base.discretisation);
        let v = MeasuredVertices::from_terms(shape, &self.terms, set.has_gradient_energy());
        let local = LocalEnergy::new(set, base);
        let constants = HessianConstants::new(set);
        let kbt = set.temperature;
        let moves = |s: usize| {
            let sp = &set.species[s];
            sp.mobility > 0.0 || (sp.reservoir == Reservoir::Bulk && sp.binding_rate > 0.0)
        };
        // The cotangent weight of each edge, from its faces' opposite
        // corners (`face_edges[f][k]` joins corners k and k + 1).
        let t = shape.topology;
        self.weights.clear();
        self.weights.resize(t.edges.len(), 0.0);
        for (edges, c) in t.face_edges.iter().zip(shape.geometry) {
            for k in 0..3 {
                self.weights[edges[(k + 1) % 3] as usize] += 0.5 * c.cot[k];
            }
        }
        for w in &mut self.weights {
            *w = w.max(0.0);
        }
        let resize = |x: &mut Vec<Vec<f64>>| {
            x.resize(ns, Vec::new());
            for y in x.iter_mut() {
                y.clear();
                y.resize(n, 0.0);
            }
        };
        for x in [
            &mut self.grad,
            &mut self.mu,
            &mut self.stiffness,
            &mut self.change,
            &mut self.trial,
        ] {
            resize(x);
        }
        self.phi = crate::species::state::fractions(set, amounts, &v.areas);
        if let Some((species, vertex, value)) = outside(&self.phi) {
            return Err(TransportError::Outside {
                species,
                vertex,
                value,
                when: "at the start of the fields' transport (the shape's step shrank the \
                       vertex's area under its proteins)",
            });
        }
        let draws = Draws::new(noise, set, &self.weights, n);
        if let Some(d) = draws.as_ref() {
            d.fill(&mut self.draws[0], 0);
        }
        let mut steps = 0;
        let mut elapsed = 0.0;
        let mut block: Block = [[0.0; MAX_SPECIES]; MAX_SPECIES];
        while elapsed < dt && (0..ns).any(moves) {
            v.free_energy(shape, &local, set, &self.phi, Some(&mut self.grad));
            for s in 0..ns {
                let a = set.species[s].area_per_protein;
                for i in 0..n {
                    self.mu[s][i] = self.grad[s][i] * a / v.areas[i];
                }
            }
            for i in 0..n {
                v.hessian(i, &constants, base, set, &self.phi, &mut block);
                for s in 0..ns {
                    let a = set.species[s].area_per_protein / v.areas[i];
                    self.stiffness[s][i] = block[s][s].abs() * a * a;
                }
            }
            // The fastest rate's bound: Gershgorin on H^½ K H^½.
            let mut fastest: f64 = 0.0;
            for s in (0..ns).filter(|&s| moves(s)) {
                let sp = &set.species[s];
                let (h, phi) = (&self.stiffness[s], &self.phi);
                self.rate.clear();
                self.rate.resize(n, 0.0);
                let scale = sp.mobility / (sp.area_per_protein * sp.area_per_protein);
                for (e, &[i, j]) in t.edges.iter().enumerate() {
                    let (i, j) = (i as usize, j as usize);
                    let k = self.weights[e] * scale * edge_mobility(phi, s, i, j).0;
                    let cross = (h[i] * h[j]).sqrt();
                    self.rate[i] += k * (h[i] + cross);
                    self.rate[j] += k * (h[j] + cross);
                }
                if sp.reservoir == Reservoir::Bulk {
                    for i in 0..n {
                        let g = v.areas[i] * sp.binding_rate * vertex_mobility(phi, s, i).0
                            / (kbt * sp.area_per_protein);
                        self.rate[i] += g * h[i];
                    }
                }
                fastest = self.rate.iter().fold(fastest, |m, &r| m.max(r));
            }
            let mut h = (dt - elapsed).min(STABLE_FRACTION / fastest);
            if let Some(d) = draws.as_ref() {
                d.fill(&mut self.draws[1], steps + 1);
            }
            let mut halvings = 0;
            loop {
                self.step_changes(&v, &t.edges, set, h, kbt, draws.is_some());
                for s in 0..ns {
                    let a = set.species[s].area_per_protein;
                    for i in 0..n {
                        self.trial[s][i] = a * (amounts[s][i] + self.change[s][i]) / v.areas[i];
                    }
                }
                match outside(&self.trial) {
                    None => break,
                    Some((species, vertex, value)) => {
                        halvings += 1;
                        if halvings > MOST_HALVINGS {
                            return Err(TransportError::Outside {
                                species,
                                vertex,
                                value,
                                when: "after a step of the fields' transport halved 40 times \
                                       (too few proteins per vertex for their noise: raise the \
                                       vertex area or lower a_p)",
                            });
                        }
                        h *= 0.5;
                    }
                }
            }
            for s in 0..ns {
                for i in 0..n {
                    amounts[s][i] += self.change[s][i];
                }
            }
            std::mem::swap(&mut self.phi, &mut self.trial);
            self.draws.swap(0, 1);
            elapsed += h;
            steps += 1;
        }
        // A conserved species' μ: the area mean of μ_i at the end,
        // Σ_i A_i μ_i / A = a_s Σ_i ∂F/∂φ_i / A.
        v.free_energy(shape, &local, set, &self.phi, Some(&mut self.grad));
        let area: f64 = v.areas.iter().sum();
        let chemical_potentials = set
            .species
            .iter()
            .zip(&self.grad)
            .map(|(sp, grad)| match sp.reservoir {
                Reservoir::Bulk => sp.chemical_potential.unwrap_or(0.0),
                Reservoir::Conserved => sp.area_per_protein * grad.iter().sum::<f64>() / area,
            })
            .collect();
        Ok(Transported {
            steps,
            chemical_potentials,
        })
    }

    /// The amounts' changes over a step of length `h` into `change`, from
    /// the chemical potentials `mu` at the fractions `phi` over the
    /// `edges` and, with `thermal`, the draws of this step and the next.
    fn step_changes(
        &mut self,
        v: &MeasuredVertices,
        edges: &[[u32; 2]],
        set: &SpeciesSet,
        h: f64,
        kbt: f64,
        thermal: bool,
    ) {
        let (phi, mu) = (&self.phi, &self.mu);
        let n = v.areas.len();
        for (s, sp) in set.species.iter().enumerate() {
            let change = &mut self.change[s];
            change.fill(0.0);
            let a = sp.area_per_protein;
            let noise = |e: usize| -> f64 {
                match thermal {
                    true => 0.5 * (self.draws[0][s][e] + self.draws[1][s][e]),
                    false => 0.0,
                }
            };
            if sp.mobility > 0.0 {
                let scale = sp.mobility / (a * a);
                for (e, &[i, j]) in edges.iter().enumerate() {
                    let (i, j) = (i as usize, j as usize);
                    let (m, dm) = edge_mobility(phi, s, i, j);
                    let k = self.weights[e] * scale * m;
                    // Down the potential, the mobility's drift, the noise.
                    let mut flux = h * k * (mu[s][j] - mu[s][i]);
                    if thermal {
                        let dk = self.weights[e] * scale * dm;
                        flux += h * kbt * dk * 0.5 * a * (1.0 / v.areas[i] - 1.0 / v.areas[j]);
                        flux += (2.0 * kbt * k * h).sqrt() * noise(e);
                    }
                    change[i] += flux;
                    change[j] -= flux;
                }
            }
            if sp.reservoir == Reservoir::Bulk && sp.binding_rate > 0.0 {
                let target = sp.chemical_potential.unwrap_or(0.0);
                let edges = self.weights.len();
                for i in 0..n {
                    let (m, dm) = vertex_mobility(phi, s, i);
                    let g = v.areas[i] * sp.binding_rate * m / (kbt * a);
                    change[i] -= h * g * (mu[s][i] - target);
                    if thermal {
                        change[i] += h * sp.binding_rate * dm;
                        change[i] += (2.0 * kbt * g * h).sqrt() * noise(edges + i);
                    }
                }
            }
        }
    }
}

/// The mobility factor φ_s(1 − Σφ) of species `s` at the mean of vertices
/// `i` and `j`, and its derivative against φ_s.
fn edge_mobility(phi: &[Vec<f64>], s: usize, i: usize, j: usize) -> (f64, f64) {
    let p = 0.5 * (phi[s][i] + phi[s][j]);
    let total: f64 = phi.iter().map(|q| 0.5 * (q[i] + q[j])).sum();
    (p * (1.0 - total), 1.0 - total - p)
}

/// The mobility factor φ_s(1 − Σφ) of species `s` at vertex `i`, and its
/// derivative against φ_s.
fn vertex_mobility(phi: &[Vec<f64>], s: usize, i: usize) -> (f64, f64) {
    let p = phi[s][i];
    let total: f64 = phi.iter().map(|q| q[i]).sum();
    (p * (1.0 - total), 1.0 - total - p)
}

/// The first (species, vertex, value) outside φ > 0, Σφ < 1.
fn outside(phi: &[Vec<f64>]) -> Option<(usize, usize, f64)> {
    let n = phi.first().map_or(0, Vec::len);
    for i in 0..n {
        let total: f64 = phi.iter().map(|p| p[i]).sum();
        for (s, p) in phi.iter().enumerate() {
            if !(p[i] > 0.0 && total < 1.0) {
                return Some((s, i, p[i]));
            }
        }
    }
    None
}

/// The draws of the fields' noise: per step, a stream seeded by (seed,
/// the run's step count), drawn species by species, a transported
/// species' edges, then a binding species' vertices.
struct Draws {
    noise: Noise,
    sizes: Vec<usize>,
}

impl Draws {
    fn new(noise: Option<Noise>, set: &SpeciesSet, weights: &[f64], n: usize) -> Option<Self> {
        let noise = noise?;
        let sizes = set
            .species
            .iter()
            .map(|sp| {
                let edges = if sp.mobility > 0.0 { weights.len() } else { 0 };
                let binding = sp.reservoir == Reservoir::Bulk && sp.binding_rate > 0.0;
                // A binding species' vertex draws follow the edges' slots.
                if binding { weights.len() + n } else { edges }
            })
            .collect();
        Some(Self { noise, sizes })
    }

    /// The draws of the tick's step `step` into `out`.
    fn fill(&self, out: &mut Vec<Vec<f64>>, step: u64) {
        let seed = stream_seed(self.noise.seed, NOISE_STREAM, self.noise.steps + step);
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        out.resize(self.sizes.len(), Vec::new());
        for (o, &size) in out.iter_mut().zip(&self.sizes) {
            o.clear();
            o.extend((0..size).map(|_| -> f64 { StandardNormal.sample(&mut rng) }));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::bending::BendingDiscretisation;
    use crate::mesh::geometry::{Corners, face_geometry};
    use crate::mesh::topology::Topology;
    use crate::mesh::{SurfaceMesh, ellipsoid};
    use crate::species::params::{Initial, Species};
    use crate::species::relax::{RelaxSettings, relax_fields};
    use crate::species::state::{amounts, fractions};

    struct Fixture {
        mesh: SurfaceMesh,
        topology: Topology,
        geometry: Vec<Corners>,
    }

    impl Fixture {
        fn ellipsoid(level: u32) -> Self {
            let mesh = ellipsoid(level, [1.0, 1.3, 0.8], 0.0, 0);
            let mut m = crate::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
            let topology = m.topology().unwrap().clone();
            let mut geometry = Vec::new();
            face_geometry(&mesh.positions, &topology.faces, &mut geometry);
            Self {
                mesh,
                topology,
                geometry,
            }
        }

        fn surface(&self) -> Surface<'_> {
            Surface {
                positions: &self.mesh.positions,
                topology: &self.topology,
                geometry: &self.geometry,
                boundary: None,
            }
        }

        fn areas(&self) -> Vec<f64> {
            crate::energy::bending_measure::vertex_areas(
                &self.topology.faces,
                &self.geometry,
                self.mesh.vertex_count(),
                BendingDiscretisation::Cotangent,
            )
        }
    }

    const BASE: BaseBending = BaseBending {
        kappa: 1.0,
        c0: 0.0,
        discretisation: BendingDiscretisation::Cotangent,
    };

    fn curving(mobility: f64, eta: f64) -> SpeciesSet {
        SpeciesSet {
            species: vec![Species {
                curvature_coupling: 1.5,
                rigidity_change: 0.5,
                gradient_energy: eta,
                mobility,
                ..Species::new("bar", 0.05, Initial::Fraction(0.2))
            }],
            interactions: vec![],
            temperature: 0.1,
        }
    }

    fn free_energy_of(f: &Fixture, set: &SpeciesSet, phi: &[Vec<f64>]) -> f64 {
        let v = MeasuredVertices::measure(f.surface(), BASE.discretisation, true);
        v.free_energy(f.surface(), &LocalEnergy::new(set, BASE), set, phi, None)
    }

    #[test]
    fn transport_conserves_the_count_and_lowers_the_free_energy() {
        let f = Fixture::ellipsoid(3);
        let set = curving(0.02, 0.05);
        let areas = f.areas();
        let n = areas.len();
        let phi: Vec<Vec<f64>> = vec![
            (0..n)
                .map(|i| 0.2 + 0.1 * (0.37 * i as f64).sin())
                .collect(),
        ];
        let mut x = amounts(&set, &phi, &areas);
        let count: f64 = x[0].iter().sum();
        let mut transport = Transport::default();
        let mut energy = free_energy_of(&f, &set, &phi);
        for _ in 0..5 {
            let done = transport
                .advance(f.surface(), BASE, &set, &mut x, 0.02, None)
                .unwrap();
            assert!(done.steps > 1, "{done:?}");
            let now = free_energy_of(&f, &set, &fractions(&set, &x, &areas));
            assert!(now < energy, "{now} after {energy}");
            energy = now;
        }
        let after: f64 = x[0].iter().sum();
        assert!(
            ((after - count) / count).abs() <= 1e-13,
            "{after} vs {count}"
        );
    }

    #[test]
    fn relaxed_fields_do_not_move_and_a_bulk_species_binds_to_them() {
        let f = Fixture::ellipsoid(3);
        let areas = f.areas();
        let n = areas.len();
        let settings = RelaxSettings {
            tolerance: 1e-12,
            max_iterations: 100,
        };
        // A conserved species at its minimum stays there.
        let set = curving(0.02, 0.0);
        let mut phi = vec![vec![0.2; n]];
        relax_fields(f.surface(), BASE, &set, &mut phi, settings).unwrap();
        let mut x = amounts(&set, &phi, &areas);
        let before = x.clone();
        Transport::default()
            .advance(f.surface(), BASE, &set, &mut x, 0.5, None)
            .unwrap();
        let moved = (0..n)
            .map(|i| ((x[0][i] - before[0][i]) / before[0][i]).abs())
            .fold(0.0, f64::max);
        assert!(moved < 1e-9, "{moved}");
        // A bulk species from a uniform start binds to the relaxed field.
        let mut set = curving(0.0, 0.0);
        set.species[0].reservoir = Reservoir::Bulk;
        set.species[0].chemical_potential = Some(-0.2);
        set.species[0].binding_rate = 3.0;
        let mut relaxed = vec![vec![0.2; n]];
        relax_fields(f.surface(), BASE, &set, &mut relaxed, settings).unwrap();
        let mut x = amounts(&set, &[vec![0.2; n]], &areas);
        let done = Transport::default()
            .advance(f.surface(), BASE, &set, &mut x, 20.0 / 3.0, None)
            .unwrap();
        let phi = fractions(&set, &x, &areas);
        let off = (0..n)
            .map(|i| (phi[0][i] - relaxed[0][i]).abs())
            .fold(0.0, f64::max);
        assert!(off < 1e-6, "{off} after {} steps", done.steps);
        assert_eq!(done.chemical_potentials, vec![-0.2]);
    }

    #[test]
    fn the_noise_is_reproducible_conserving_and_keeps_the_fields_inside() {
        // About 40 proteins per vertex.
        let f = Fixture::ellipsoid(2);
        let mut set = curving(0.02, 0.0);
        set.species[0].area_per_protein = 0.0004;
        let areas = f.areas();
        let start = amounts(&set, &[vec![0.2; areas.len()]], &areas);
        let run = |set: &SpeciesSet, seed: u64| {
            let mut x = start.clone();
            let mut transport = Transport::default();
            let mut steps = 0;
            for _ in 0..20 {
                let noise = Noise { seed, steps };
                steps += transport
                    .advance(f.surface(), BASE, set, &mut x, 1e-4, Some(noise))?
                    .steps;
            }
            Ok::<_, TransportError>(x)
        };
        let (a, b, c) = (
            run(&set, 7).unwrap(),
            run(&set, 7).unwrap(),
            run(&set, 8).unwrap(),
        );
        assert_eq!(a, b);
        assert_ne!(a, c);
        let count = |x: &[Vec<f64>]| x[0].iter().sum::<f64>();
        assert!(((count(&a) - count(&start)) / count(&start)).abs() < 1e-13);
        let moved = (0..areas.len())
            .map(|i| ((a[0][i] - start[0][i]) / start[0][i]).abs())
            .fold(0.0, f64::max);
        assert!(moved > 1e-2, "the noise moved the fields by {moved} only");
        // A third of a protein per vertex: the noise empties a vertex.
        set.species[0].area_per_protein = 0.05;
        let start = amounts(&set, &[vec![0.2; areas.len()]], &areas);
        let mut x = start.clone();
        let noise = Some(Noise { seed: 7, steps: 0 });
        let err = Transport::default()
            .advance(f.surface(), BASE, &set, &mut x, 1.0, noise)
            .unwrap_err();
        assert!(
            err.to_string().contains("too few proteins per vertex"),
            "{err}"
        );
    }
}
