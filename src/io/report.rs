//! The energy report of `remembrane energy`: energies by term, area, volume,
//! reduced volume and mesh quality, as text or JSON; per-vertex forces as CSV.

use crate::engine::force::ForceBuffers;
use crate::engine::simulation::{DensePositions, Simulation};
use crate::mesh::geometry::{enclosed_volume, reduced_volume, total_area};
use crate::mesh::quality::MeshQuality;
use serde::Serialize;
use std::fmt::Write as _;

/// Energy of one term.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct TermEnergy {
    /// Term name.
    pub term: String,
    /// Energy (Ē = 10 k_BT).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub energy: f64,
}

/// The energy of each force term of the last evaluation, in order.
pub fn term_energies(buffers: &ForceBuffers) -> Vec<TermEnergy> {
    buffers
        .names()
        .into_iter()
        .zip(&buffers.evaluation.energies)
        .map(|(term, &energy)| TermEnergy { term, energy })
        .collect()
}

/// State summary of a membrane.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct EnergyReport {
    /// Scene name.
    pub scene: String,
    /// Vertex count.
    pub vertices: usize,
    /// Edge count.
    pub edges: usize,
    /// Face count.
    pub faces: usize,
    /// Energy by term, in evaluation order.
    pub energies: Vec<TermEnergy>,
    /// Sum of all terms (Ē).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub total_energy: f64,
    /// Total area (l̄²).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub area: f64,
    /// Enclosed volume (l̄³); `None` (null in JSON) for an open membrane,
    /// which encloses none.
    pub volume: Option<f64>,
    /// Reduced volume 6√π V / A^{3/2}; `None` for an open membrane.
    pub reduced_volume: Option<f64>,
    /// Mesh quality.
    pub quality: MeshQuality,
}

impl EnergyReport {
    /// Summarises the last force evaluation of `sim` (call
    /// [`crate::engine::simulation::Simulation::evaluate_forces`] first).
    pub fn new(scene: &str, sim: &Simulation) -> Self {
        let membrane = sim.membrane();
        let t = membrane.cached_topology();
        let positions = sim.resource::<DensePositions>();
        let p = &positions.0;
        let area = total_area(p, &t.faces);
        let volume = (!t.is_open()).then(|| enclosed_volume(p, &t.faces, p[0]));
        let energies = term_energies(&sim.resource::<ForceBuffers>());
        Self {
            scene: scene.to_string(),
            vertices: t.vertex_count(),
            edges: t.edges.len(),
            faces: t.faces.len(),
            total_energy: energies.iter().map(|e| e.energy).sum(),
            energies,
            area,
            volume,
            reduced_volume: volume.map(|v| reduced_volume(v, area)),
            quality: MeshQuality::measure(t, p),
        }
    }

    /// Human-readable multi-line summary.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let q = &self.quality;
        let _ = writeln!(
            s,
            "scene {}: {} vertices, {} edges, {} faces",
            self.scene, self.vertices, self.edges, self.faces
        );
        let _ = writeln!(s, "energy (Ē = 10 k_BT):");
        for e in &self.energies {
            let _ = writeln!(s, "  {:<16} {:>16.9}", e.term, e.energy);
        }
        let _ = writeln!(s, "  {:<16} {:>16.9}", "total", self.total_energy);
        match (self.volume, self.reduced_volume) {
            (Some(v), Some(rv)) => writeln!(
                s,
                "area {:.6} l̄²   volume {v:.6} l̄³   reduced volume {rv:.6}",
                self.area
            ),
            _ => writeln!(s, "area {:.6} l̄²   (open: no enclosed volume)", self.area),
        }
        .ok();
        let _ = writeln!(
            s,
            "edges min/mean/max/std {:.4} / {:.4} / {:.4} / {:.4} l̄   min angle {:.2}°",
            q.edge_min, q.edge_mean, q.edge_max, q.edge_std, q.min_angle_deg
        );
        let hist: Vec<String> = q
            .valence_histogram
            .iter()
            .map(|(v, n)| format!("{v}:{n}"))
            .collect();
        let _ = writeln!(s, "valence histogram {}", hist.join(" "));
        s
    }
}

/// Per-vertex forces as CSV: `vertex,x,y,z`, then `<term>_fx,_fy,_fz` for
/// each term (its exact −∇E), `smoothed_penalty_fx,…` when the scene has
/// penalty terms (their sum after 1-ring smoothing), and `total_fx,…`, the
/// force the dynamics uses (Ē/l̄).
pub fn forces_csv(sim: &Simulation) -> String {
    let buffers = sim.resource::<ForceBuffers>();
    let ev = &buffers.evaluation;
    let mut names = buffers.names();
    if !ev.smoothed_penalty.is_empty() {
        names.push("smoothed_penalty".into());
    }
    let mut s = String::from("vertex,x,y,z");
    for n in names.iter().map(String::as_str).chain(["total"]) {
        let _ = write!(s, ",{n}_fx,{n}_fy,{n}_fz");
    }
    s.push('\n');
    for (i, p) in sim.resource::<DensePositions>().0.iter().enumerate() {
        let _ = write!(s, "{i},{:e},{:e},{:e}", p.x, p.y, p.z);
        let smoothed = ev.smoothed_penalty.get(i).copied();
        for f in ev
            .term_forces
            .iter()
            .map(|f| f[i])
            .chain(smoothed)
            .chain([ev.total[i]])
        {
            let _ = write!(s, ",{:e},{:e},{:e}", f.x, f.y, f.z);
        }
        s.push('\n');
    }
    s
}
