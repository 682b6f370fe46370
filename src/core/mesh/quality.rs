//! Mesh-quality statistics: edge lengths, smallest angle, valence histogram.

use crate::mesh::topology::Topology;
use glam::DVec3;
use serde::Serialize;
use std::collections::BTreeMap;

/// Mesh-quality statistics of a membrane.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct MeshQuality {
    /// Shortest edge (l̄).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub edge_min: f64,
    /// Mean edge length (l̄).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub edge_mean: f64,
    /// Longest edge (l̄).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub edge_max: f64,
    /// Sample standard deviation of edge lengths (l̄).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub edge_std: f64,
    /// Smallest interior angle of any face (degrees).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub min_angle_deg: f64,
    /// Number of vertices with each valence.
    #[serde(deserialize_with = "valence_keys")]
    pub valence_histogram: BTreeMap<usize, usize>,
}

/// Reads the histogram's keys, which JSON writes as strings, also where
/// the report is flattened into another object (serde's flattening hands
/// them over as strings, not as the numbers a map key would parse into).
fn valence_keys<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<BTreeMap<usize, usize>, D::Error> {
    use serde::Deserialize;
    BTreeMap::<String, usize>::deserialize(d)?
        .into_iter()
        .map(|(k, n)| {
            k.parse()
                .map(|k| (k, n))
                .map_err(|_| serde::de::Error::custom(format!("valence `{k}` is not a number")))
        })
        .collect()
}

impl MeshQuality {
    /// Statistics of the mesh given by `topology` at `positions`.
    pub fn measure(topology: &Topology, positions: &[DVec3]) -> Self {
        let lengths: Vec<f64> = topology
            .edges
            .iter()
            .map(|&[a, b]| positions[a as usize].distance(positions[b as usize]))
            .collect();
        let n = lengths.len() as f64;
        let mean = lengths.iter().sum::<f64>() / n;
        let var = lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
        let mut min_angle = f64::INFINITY;
        for f in &topology.faces {
            let p = f.map(|v| positions[v as usize]);
            for k in 0..3 {
                let u = p[(k + 1) % 3] - p[k];
                let v = p[(k + 2) % 3] - p[k];
                min_angle = min_angle.min(u.angle_between(v));
            }
        }
        let mut valence_histogram = BTreeMap::new();
        for v in 0..topology.vertex_count() {
            *valence_histogram.entry(topology.valence(v)).or_insert(0) += 1;
        }
        Self {
            edge_min: lengths.iter().copied().fold(f64::INFINITY, f64::min),
            edge_mean: mean,
            edge_max: lengths.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            edge_std: var.sqrt(),
            min_angle_deg: min_angle.to_degrees(),
            valence_histogram,
        }
    }
}
