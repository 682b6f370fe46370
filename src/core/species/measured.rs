//! The species' free energy at a fixed shape, vertex by vertex. The
//! vertices' areas, curvatures and Dirichlet diagonals are measured once
//! ([`MeasuredVertices::measure`]); on them, F and ∂F/∂φ at any fields
//! ([`MeasuredVertices::free_energy`]) and each vertex's local Hessian
//! block ([`MeasuredVertices::hessian`]) cost one pass over the vertices.
//! The fields' relaxation ([`crate::species::relax`]) and their transport
//! ([`crate::species::transport`]) evaluate these many times per shape.

use crate::energy::bending::BendingDiscretisation;
use crate::energy::bending_measure::{Surface, VertexTerms};
use crate::species::free_energy::{BaseBending, LocalEnergy, LocalValues, gradient_energy};
use crate::species::params::{MAX_SPECIES, SpeciesSet};

/// A dense symmetric S×S block, S ≤ [`MAX_SPECIES`].
pub(crate) type Block = [[f64; MAX_SPECIES]; MAX_SPECIES];

/// The per-vertex quantities of a fixed shape.
pub(crate) struct MeasuredVertices {
    /// Vertex areas A_i (l̄²) in the bending's discretisation.
    pub(crate) areas: Vec<f64>,
    /// Signed total curvatures h_i (1/l̄).
    pub(crate) curvature: Vec<f64>,
    /// Whether each vertex carries the coupled bending (not on a rim).
    pub(crate) interior: Vec<bool>,
    /// Σ of ½cot over the face edges at each vertex (the Dirichlet
    /// energy's diagonal per unit η), at least 0.
    pub(crate) dirichlet: Vec<f64>,
}

/// The constants of a species set that the local Hessian reads.
pub(crate) struct HessianConstants {
    kbt: f64,
    a0: f64,
    chi: Vec<Vec<f64>>,
    /// 1/a_s per species.
    pub(crate) inv_ap: [f64; MAX_SPECIES],
}

impl HessianConstants {
    /// The constants of `set`.
    pub(crate) fn new(set: &SpeciesSet) -> Self {
        let mut inv_ap = [0.0; MAX_SPECIES];
        for (k, sp) in set.species.iter().enumerate() {
            inv_ap[k] = 1.0 / sp.area_per_protein;
        }
        Self {
            kbt: set.temperature,
            a0: set.solvent_area(),
            chi: set.interaction_matrix(),
            inv_ap,
        }
    }
}

impl MeasuredVertices {
    /// The quantities of `shape` in the bending's `form`; the Dirichlet
    /// diagonal only with `gradients` (a species has a gradient energy),
    /// else zeros.
    pub(crate) fn measure(
        shape: Surface<'_>,
        form: BendingDiscretisation,
        gradients: bool,
    ) -> Self {
        let mut terms = VertexTerms::default();
        terms.measure(shape, form);
        Self::with(shape, terms.areas, terms.curvature, gradients)
    }

    /// The quantities of `shape` from its measure `terms` (copied).
    pub(crate) fn from_terms(shape: Surface<'_>, terms: &VertexTerms, gradients: bool) -> Self {
        Self::with(
            shape,
            terms.areas.clone(),
            terms.curvature.clone(),
            gradients,
        )
    }

    fn with(shape: Surface<'_>, areas: Vec<f64>, curvature: Vec<f64>, gradients: bool) -> Self {
        let n = shape.vertex_count();
        let interior = (0..n).map(|i| shape.is_interior(i)).collect();
        let mut dirichlet = vec![0.0; n];
        let faces = if gradients { shape.faces() } else { &[] };
        for (face, c) in faces.iter().zip(shape.geometry) {
            for k in 0..3 {
                for v in [face[(k + 1) % 3], face[(k + 2) % 3]] {
                    dirichlet[v as usize] += 0.5 * c.cot[k];
                }
            }
        }
        for d in &mut dirichlet {
            *d = d.max(0.0);
        }
        Self {
            areas,
            curvature,
            interior,
            dirichlet,
        }
    }

    /// The species' free energy F (Ē) at the fractions `phi` (by species,
    /// then dense slot) on these vertices of `shape`: the local energies,
    /// then the gradient energies. With `grad`, writes ∂F/∂φ_s,i (Ē).
    pub(crate) fn free_energy(
        &self,
        shape: Surface<'_>,
        local: &LocalEnergy<'_>,
        set: &SpeciesSet,
        phi: &[Vec<f64>],
        grad: Option<&mut [Vec<f64>]>,
    ) -> f64 {
        self.free_energy_recorded(shape, local, set, phi, grad, None)
    }

    /// [`MeasuredVertices::free_energy`], writing each vertex's local
    /// energy per area f_i and ∂f_i/∂h_i into `record` (sized here).
    pub(crate) fn free_energy_recorded(
        &self,
        shape: Surface<'_>,
        local: &LocalEnergy<'_>,
        set: &SpeciesSet,
        phi: &[Vec<f64>],
        mut grad: Option<&mut [Vec<f64>]>,
        mut record: Option<&mut LocalValues>,
    ) -> f64 {
        if let Some(r) = record.as_deref_mut() {
            r.f.resize(self.areas.len(), 0.0);
            r.df_dh.resize(self.areas.len(), 0.0);
        }
        let ns = set.species.len();
        let (mut at, mut d) = ([0.0; MAX_SPECIES], [0.0; MAX_SPECIES]);
        let mut f = 0.0;
        for i in 0..self.areas.len() {
            for (k, p) in phi.iter().enumerate() {
                at[k] = p[i];
            }
            let h = self.interior[i].then_some(self.curvature[i]);
            let (fi, df_dh) = local.at(&at[..ns], h, &mut d);
            f += self.areas[i] * fi;
            if let Some(r) = record.as_deref_mut() {
                (r.f[i], r.df_dh[i]) = (fi, df_dh);
            }
            if let Some(g) = grad.as_deref_mut() {
                for (k, g) in g.iter_mut().enumerate() {
                    g[i] = self.areas[i] * d[k];
                }
            }
        }
        if set.has_gradient_energy() {
            f += gradient_energy(shape.faces(), shape.geometry, set, phi, grad, None);
        }
        f
    }

    /// Vertex `i`'s S×S block of ∂²F/∂φ_s∂φ_t (Ē) at the fractions `phi`:
    /// the local energy's exact Hessian times A_i, plus the gradient
    /// energies' diagonal. Every entry of the S×S corner of `h` is written.
    pub(crate) fn hessian(
        &self,
        i: usize,
        c: &HessianConstants,
        base: BaseBending,
        set: &SpeciesSet,
        phi: &[Vec<f64>],
        h: &mut Block,
    ) {
        let ns = set.species.len();
        let a = self.areas[i];
        let bare = 1.0 - phi.iter().map(|p| p[i]).sum::<f64>();
        let (mut kappa, mut c0) = (base.kappa, base.c0);
        for (k, sp) in set.species.iter().enumerate() {
            kappa += sp.rigidity_change * phi[k][i];
            c0 += sp.curvature_coupling * phi[k][i];
        }
        let d = self.curvature[i] - c0;
        let solvent = c.kbt / (c.a0 * bare);
        for s in 0..ns {
            let ss = &set.species[s];
            for t in 0..ns {
                let st = &set.species[t];
                let mut x = solvent;
                x += if s == t {
                    c.kbt * c.inv_ap[s] / phi[s][i] + 2.0 * c.chi[s][s]
                } else {
                    c.chi[s.min(t)][s.max(t)]
                };
                if self.interior[i] {
                    x += kappa * ss.curvature_coupling * st.curvature_coupling
                        - d * (ss.rigidity_change * st.curvature_coupling
                            + st.rigidity_change * ss.curvature_coupling);
                }
                h[s][t] = a * x;
            }
            h[s][s] += ss.gradient_energy * self.dirichlet[i];
        }
    }
}
