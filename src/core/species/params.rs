//! The parameters of protein species: what each species costs and gains
//! per area, with its units. Mem3DG's map onto them as K_b = κ, Kbc = Δκ,
//! H0c = c/2 (it writes 2K_b(H − H0)² with H = (c1 + c2)/2), ε = ε per
//! area, ξ = k_BT/a_p, η = η; FreeDTS's C0 is c.
//!
//! A species is an area fraction φ ∈ [0, 1] on the surface. Its free
//! energy per area, added to the membrane's (f_b = ½κ(C − C0)² with the
//! total curvature C = 2H), is
//!
//! - the coupled bending ½κ_i (C − C0_i)² − ½κ (C − C0), with
//!   κ_i = κ + Σ_s Δκ_s φ_s and C0_i = C0 + Σ_s c_s φ_s;
//! - the binding Σ_s ε_s φ_s and the pair interactions Σ_{s≤t} χ_st φ_s φ_t;
//! - the ideal mixing entropy k_BT [Σ_s (φ_s/a_s) ln φ_s + (Φ̄/a_0) ln Φ̄],
//!   Φ̄ = 1 − Σ_s φ_s, with a_0 the smallest a_s (for one species this is
//!   (k_BT/a_p)[φ ln φ + (1 − φ) ln(1 − φ)]);
//!
//! and over the surface the gradient energy Σ_s ½η_s ∫|∇φ_s|².

use serde::{Deserialize, Serialize};

/// The most species a scene may declare (each has its own per-vertex
/// component).
pub const MAX_SPECIES: usize = 8;

/// One protein species.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Species {
    /// Its name: the `phi_<name>` vertex property and series columns.
    pub name: String,
    /// Area per protein a_p (l̄²): a protein count is Σ_i A_i φ_i / a_p.
    pub area_per_protein: f64,
    /// Spontaneous-curvature coupling c_s (1/l̄, total curvature): a fully
    /// covered membrane prefers C = C0 + c_s.
    #[serde(default)]
    pub curvature_coupling: f64,
    /// Rigidity change Δκ_s (Ē): κ_i = κ + Σ_s Δκ_s φ_s.
    #[serde(default)]
    pub rigidity_change: f64,
    /// Binding energy ε_s (Ē/l̄²) per area at full coverage (negative:
    /// binding is favourable).
    #[serde(default)]
    pub binding_energy: f64,
    /// Gradient energy η_s (Ē): ½η_s ∫|∇φ_s|², a line tension between
    /// covered and bare membrane.
    #[serde(default)]
    pub gradient_energy: f64,
    /// The field it starts from.
    pub initial: Initial,
    /// Where its proteins come from (default [`Reservoir::Conserved`]).
    #[serde(default)]
    pub reservoir: Reservoir,
    /// The bulk's chemical potential μ (Ē per protein) of a species
    /// [`Reservoir::Bulk`]; a conserved species' μ is computed (the
    /// multiplier of its count), so it is not given.
    #[serde(default)]
    pub chemical_potential: Option<f64>,
    /// Mobility M_s (l̄⁴/(Ē·s)) of its transport along the membrane in
    /// overdamped dynamics, ∂φ/∂t = ∇·(M φ(1 − Σφ) ∇δF/δφ): in the dilute
    /// limit a diffusion of coefficient D = M k_BT / a_p (default 0: the
    /// proteins stay where they are on the surface).
    #[serde(default)]
    pub mobility: f64,
    /// Binding rate Γ_s (1/s) of a species bound from a bulk, in overdamped
    /// dynamics: ∂φ/∂t = −Γ (a_p/k_BT) φ(1 − Σφ) (δF/δφ − μ/a_p), so a
    /// dilute coverage relaxes to the bulk's at rate Γ (default 0: no
    /// exchange during dynamics).
    #[serde(default)]
    pub binding_rate: f64,
}

/// The field a species starts from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Initial {
    /// A uniform area fraction φ, in (0, 1) (the mixing entropy's chemical
    /// potential diverges at 0 and 1).
    Fraction(f64),
    /// A protein count N, spread uniformly: φ = N a_p / A on a membrane of
    /// area A, which must be below 1.
    Count(f64),
}

/// Where a species' proteins come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Reservoir {
    /// The protein count on the membrane is fixed; the chemical potential
    /// is the multiplier that holds it, and it is reported.
    #[default]
    Conserved,
    /// Proteins bind from and unbind to a bulk at a fixed chemical
    /// potential (`chemical_potential`); the count follows.
    Bulk,
}

/// A pair interaction χ φ_a φ_b per area between two species (or a species
/// with itself: a = b gives χ φ_a²).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Interaction {
    /// The two species' names.
    pub species: (String, String),
    /// χ (Ē/l̄²); positive: the pair costs energy (demixing).
    pub chi: f64,
}

/// The species of a scene and what they share.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeciesSet {
    /// The species, in the order of their fields.
    pub species: Vec<Species>,
    /// Pair interactions (default none).
    #[serde(default)]
    pub interactions: Vec<Interaction>,
    /// k_BT of the mixing entropy (Ē; default 0.1 Ē = 300 K in the paper's
    /// units).
    #[serde(default = "default_temperature")]
    pub temperature: f64,
}

fn default_temperature() -> f64 {
    0.1
}

/// What is wrong with a species set: the field and the reason.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct SpeciesError {
    /// The field, e.g. `species[1].area_per_protein`.
    pub field: String,
    /// Why it is refused.
    pub reason: String,
}

impl Species {
    /// A conserved species named `name` with area per protein `area_per_protein`
    /// (l̄²) and the `initial` field, without couplings, binding or gradient
    /// energy; set the other fields by struct update.
    pub fn new(name: &str, area_per_protein: f64, initial: Initial) -> Self {
        Self {
            name: name.into(),
            area_per_protein,
            curvature_coupling: 0.0,
            rigidity_change: 0.0,
            binding_energy: 0.0,
            gradient_energy: 0.0,
            initial,
            reservoir: Reservoir::Conserved,
            chemical_potential: None,
            mobility: 0.0,
            binding_rate: 0.0,
        }
    }
}

impl SpeciesSet {
    /// Whether any species has a gradient energy η_s ≠ 0.
    pub fn has_gradient_energy(&self) -> bool {
        self.species.iter().any(|s| s.gradient_energy != 0.0)
    }

    /// Checks every value: names unique and non-empty, a_p > 0 and every
    /// parameter finite, k_BT > 0, interactions naming declared species.
    pub fn validate(&self) -> Result<(), SpeciesError> {
        let err = |field: String, reason: &str| {
            Err(SpeciesError {
                field,
                reason: reason.to_string(),
            })
        };
        if self.species.is_empty() {
            return err("species".into(), "declare at least one species");
        }
        if self.species.len() > MAX_SPECIES {
            return err(
                "species".into(),
                &format!("at most {MAX_SPECIES} species can be declared"),
            );
        }
        for (k, s) in self.species.iter().enumerate() {
            if s.name.is_empty() || !s.name.chars().all(|c| c.is_alphanumeric() || c == '_') {
                return err(
                    format!("species[{k}].name"),
                    "must be non-empty letters, digits or _",
                );
            }
            if self.species[..k].iter().any(|t| t.name == s.name) {
                return err(format!("species[{k}].name"), "names must be unique");
            }
            if !(s.area_per_protein > 0.0 && s.area_per_protein.is_finite()) {
                return err(
                    format!("species[{k}].area_per_protein"),
                    "must be positive and finite (l̄²)",
                );
            }
            for (field, v) in [
                ("curvature_coupling", s.curvature_coupling),
                ("rigidity_change", s.rigidity_change),
                ("binding_energy", s.binding_energy),
                ("gradient_energy", s.gradient_energy),
            ] {
                if !v.is_finite() {
                    return err(format!("species[{k}].{field}"), "must be finite");
                }
            }
            match s.initial {
                Initial::Fraction(x) if !(x > 0.0 && x < 1.0) => {
                    return err(
                        format!("species[{k}].initial"),
                        &format!(
                            "the fraction {x} is outside (0, 1): the mixing entropy's chemical \
                             potential diverges at 0 and 1 (start an absent species at a small \
                             fraction)"
                        ),
                    );
                }
                Initial::Count(c) if !(c > 0.0 && c.is_finite()) => {
                    return err(
                        format!("species[{k}].initial"),
                        &format!("the count {c} must be positive and finite (proteins)"),
                    );
                }
                _ => {}
            }
            match (s.reservoir, s.chemical_potential) {
                (Reservoir::Conserved, Some(_)) => {
                    return err(
                        format!("species[{k}].chemical_potential"),
                        "a conserved species' chemical potential is the multiplier of its \
                         count, computed, not given (declare reservoir: Bulk to bind from a \
                         bulk at this potential)",
                    );
                }
                (Reservoir::Bulk, None) => {
                    return err(
                        format!("species[{k}].chemical_potential"),
                        "a species bound from a bulk needs the bulk's chemical potential \
                         (Ē per protein)",
                    );
                }
                (Reservoir::Bulk, Some(mu)) if !mu.is_finite() => {
                    return err(format!("species[{k}].chemical_potential"), "must be finite");
                }
                _ => {}
            }
            for (field, v, unit) in [
                ("mobility", s.mobility, "l̄⁴/(Ē·s)"),
                ("binding_rate", s.binding_rate, "1/s"),
            ] {
                if !(v >= 0.0 && v.is_finite()) {
                    return err(
                        format!("species[{k}].{field}"),
                        &format!("{v} must be zero or positive and finite ({unit})"),
                    );
                }
            }
            if s.binding_rate > 0.0 && s.reservoir == Reservoir::Conserved {
                return err(
                    format!("species[{k}].binding_rate"),
                    "a conserved species does not bind from a bulk (declare reservoir: Bulk \
                     with its chemical_potential)",
                );
            }
            if s.gradient_energy < 0.0 {
                return err(
                    format!("species[{k}].gradient_energy"),
                    "must not be negative (the energy would favour sharp fronts)",
                );
            }
        }
        let total: f64 = self
            .species
            .iter()
            .filter_map(|s| match s.initial {
                Initial::Fraction(x) => Some(x),
                Initial::Count(_) => None,
            })
            .sum();
        if total >= 1.0 {
            return err(
                "species".into(),
                &format!("the initial fractions sum to {total}, not below 1"),
            );
        }
        for (k, i) in self.interactions.iter().enumerate() {
            for name in [&i.species.0, &i.species.1] {
                if self.index(name).is_none() {
                    return err(
                        format!("interactions[{k}].species"),
                        &format!("no species named {name:?}"),
                    );
                }
            }
            if !i.chi.is_finite() {
                return err(format!("interactions[{k}].chi"), "must be finite");
            }
        }
        if !(self.temperature > 0.0 && self.temperature.is_finite()) {
            return err("temperature".into(), "must be positive and finite (Ē)");
        }
        Ok(())
    }

    /// The position of the species named `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.species.iter().position(|s| s.name == name)
    }

    /// a_0 of the solvent's entropy: the smallest area per protein.
    pub fn solvent_area(&self) -> f64 {
        self.species
            .iter()
            .map(|s| s.area_per_protein)
            .fold(f64::INFINITY, f64::min)
    }

    /// The interactions as a symmetric matrix χ_st (a pair declared twice
    /// adds up), with the diagonal counted once: Σ_{s≤t} χ_st φ_s φ_t.
    /// Names are assumed valid ([`SpeciesSet::validate`]).
    pub fn interaction_matrix(&self) -> Vec<Vec<f64>> {
        let n = self.species.len();
        let mut chi = vec![vec![0.0; n]; n];
        for i in &self.interactions {
            let (Some(a), Some(b)) = (self.index(&i.species.0), self.index(&i.species.1)) else {
                continue;
            };
            let (a, b) = (a.min(b), a.max(b));
            chi[a][b] += i.chi;
        }
        chi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(name: &str) -> Species {
        Species {
            curvature_coupling: 2.0,
            ..Species::new(name, 0.01, Initial::Fraction(0.1))
        }
    }

    #[test]
    fn bad_species_name_the_field_and_the_reason() {
        let mut set = SpeciesSet {
            species: vec![one("bar"), one("bar")],
            interactions: vec![],
            temperature: 0.1,
        };
        assert_eq!(
            set.validate().unwrap_err().to_string(),
            "species[1].name: names must be unique"
        );
        set.species[1].name = "epsin".into();
        set.species[1].area_per_protein = 0.0;
        assert_eq!(
            set.validate().unwrap_err().field,
            "species[1].area_per_protein"
        );
        set.species[1].area_per_protein = 0.02;
        set.interactions.push(Interaction {
            species: ("bar".into(), "dynamin".into()),
            chi: 1.0,
        });
        let e = set.validate().unwrap_err();
        assert_eq!(e.field, "interactions[0].species");
        assert!(e.reason.contains("dynamin"), "{e}");
        set.interactions[0].species.1 = "epsin".into();
        set.species[1].chemical_potential = Some(-0.3);
        assert_eq!(
            set.validate().unwrap_err().field,
            "species[1].chemical_potential"
        );
        set.species[1].reservoir = Reservoir::Bulk;
        assert_eq!(set.validate(), Ok(()));
        set.species[1].chemical_potential = None;
        let e = set.validate().unwrap_err();
        assert_eq!(e.field, "species[1].chemical_potential");
        assert!(e.reason.contains("bulk"), "{e}");
        set.species[1].chemical_potential = Some(-0.3);
        assert_eq!(set.validate(), Ok(()));
        assert_eq!(set.solvent_area(), 0.01);
        assert_eq!(
            set.interaction_matrix(),
            vec![vec![0.0, 1.0], vec![0.0, 0.0]]
        );
    }
}
