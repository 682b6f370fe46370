//! Split and merge of one edge (SPEC §4) on top of the mesh-edit layer.
//!
//! For an edge (i1, i2): j1 is the apex of the face (i1, i2, j1), j2 of
//! (i2, i1, j2); k1…k4 are the far apexes across edges i1–j1, j1–i2, i2–j2
//! and j2–i1. A split inserts n at the midpoint and re-triangulates the four
//! quadrilaterals (i1, n, j1, k1), (n, i2, k2, j1), (i2, n, j2, k3),
//! (n, i1, k4, j2), each by its old i–j diagonal or the new k–n one
//! (2⁴ = 16 options). A merge moves i1 to the midpoint, removes i2 (its
//! other faces are relabelled to i1) and re-triangulates (j1, k1, i, k2) and
//! (j2, k3, i, k4) by i–j or k–k (2² = 4 options). Options that the edit
//! layer rejects (valence range, non-manifold results) are dropped; the one
//! with the least valence variance over the affected vertices wins, ties
//! broken by the most uniform lengths of the quadrilaterals' diagonals.
//!
//! Every per-vertex field follows its transfer policy
//! ([`crate::mesh::vertex_field`]); lipid density is conserved: split ρ_i1, ρ_i2
//! ×= 2/3 and ρ_n = (ρ_i1 + ρ_i2)/3; merge ρ_i = ρ_i1 + ρ_i2.

pub mod flip;
pub mod relax;

use crate::mesh::ValenceRange;
use crate::mesh::components::Position;
use crate::mesh::edit::{EditError, KeptFaces, PatchEdit};
use crate::mesh::membrane::Membrane;
use crate::mesh::vertex_field::TransferPolicy;
use glam::DVec3;
use hecs::Entity;
use std::sync::Arc;

/// The vertices and faces around an edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeRegion {
    /// The edge's end points.
    pub i: [Entity; 2],
    /// Apexes of the faces (i1, i2, j1) and (i2, i1, j2).
    pub j: [Entity; 2],
    /// Far apexes across i1–j1, j1–i2, i2–j2, j2–i1.
    pub k: [Entity; 4],
    /// Faces (i1, i2, j1), (i2, i1, j2).
    pub central: [Entity; 2],
    /// Faces (i1, j1, k1), (j1, i2, k2), (i2, j2, k3), (j2, i1, k4).
    pub outer: [Entity; 4],
}

/// A candidate re-triangulation, built in full ([`Candidates::get`]).
#[derive(Clone, Debug)]
pub struct Candidate {
    /// For each quadrilateral: `true` = the new diagonal (k–n or k–k).
    pub diagonals: Vec<bool>,
    /// The edit.
    pub edit: PatchEdit,
    /// The chosen diagonal of every quadrilateral (vertex pairs, old or
    /// new); the spread of their lengths breaks valence ties.
    pub diagonal_edges: Vec<(Entity, Entity)>,
}

/// Why an edge could not be split or merged.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RemeshError {
    /// The region around the edge is not the generic two-triangle,
    /// four-neighbour configuration (e.g. a tetrahedral neighbourhood).
    #[error("the neighbourhood of the edge is degenerate")]
    DegenerateRegion,
    /// No re-triangulation keeps the mesh valid with valences in range.
    #[error("no valid re-triangulation (last rejection: {0})")]
    NoValidOption(EditError),
    /// The edge slot is not one of the current topology's.
    #[error("edge slot {0} is not an edge of the mesh")]
    NoSuchEdge(u32),
}

/// Finds the region around edge slot `edge` of the current topology.
pub fn edge_region(m: &Membrane, edge: u32) -> Result<EdgeRegion, RemeshError> {
    let t = m.cached_topology();
    let (Some(&[a, b]), Some(&[fl, fr])) =
        (t.edges.get(edge as usize), t.edge_faces.get(edge as usize))
    else {
        return Err(RemeshError::NoSuchEdge(edge));
    };
    let ent = |v: u32| t.vertex_entities[v as usize];
    // Apex of face f opposite the directed edge x → y.
    let apex = |f: u32, x: u32, y: u32| -> Option<u32> {
        let tri = t.faces[f as usize];
        (0..3)
            .find(|&m| tri[m] == x && tri[(m + 1) % 3] == y)
            .map(|m| tri[(m + 2) % 3])
    };
    // Face across the directed edge x → y (the one traversing y → x).
    let across = |x: u32, y: u32| -> Option<(u32, u32)> {
        let k = t.neighbours(y as usize).iter().position(|&w| w == x);
        k.map(|k| {
            // Ring face k of y is (y, x, next): it traverses y → x.
            let f = t.ring_faces_of(y as usize)[k];
            (f, apex(f, y, x).unwrap_or(u32::MAX))
        })
    };
    let j1 = apex(fl, a, b).ok_or(RemeshError::DegenerateRegion)?;
    let j2 = apex(fr, b, a).ok_or(RemeshError::DegenerateRegion)?;
    if j1 == j2 {
        return Err(RemeshError::DegenerateRegion);
    }
    // Outer faces: (i1, j1, k1) traverses i1 → j1, i.e. the face across j1 → i1.
    let (o1, k1) = across(j1, a).ok_or(RemeshError::DegenerateRegion)?;
    let (o2, k2) = across(b, j1).ok_or(RemeshError::DegenerateRegion)?;
    let (o3, k3) = across(j2, b).ok_or(RemeshError::DegenerateRegion)?;
    let (o4, k4) = across(a, j2).ok_or(RemeshError::DegenerateRegion)?;
    let ks = [k1, k2, k3, k4];
    let faces = [fl, fr, o1, o2, o3, o4];
    let distinct = faces
        .iter()
        .enumerate()
        .all(|(x, f)| !faces[..x].contains(f));
    if ks.contains(&u32::MAX) || !distinct || ks.iter().any(|k| [a, b].contains(k)) {
        return Err(RemeshError::DegenerateRegion);
    }
    let fe = |f: u32| t.face_entities[f as usize];
    Ok(EdgeRegion {
        i: [ent(a), ent(b)],
        j: [ent(j1), ent(j2)],
        k: ks.map(ent),
        central: [fe(fl), fe(fr)],
        outer: [fe(o1), fe(o2), fe(o3), fe(o4)],
    })
}

/// A quadrilateral of a split or merge: the two faces with its old
/// diagonal, the two with the new one, and both diagonals.
type Quad = (
    [[Entity; 3]; 2],
    [[Entity; 3]; 2],
    (Entity, Entity),
    (Entity, Entity),
);

/// The candidate re-triangulations of one split or merge: the edit they
/// share (faces removed, vertices added, removed or moved, faces added
/// outside the quadrilaterals) and each quadrilateral's faces with its old
/// and its new diagonal. Candidate `bits` takes quad q's new diagonal when
/// bit q is set. Candidates are built on demand, not stored.
#[derive(Clone, Debug)]
pub struct Candidates {
    base: PatchEdit,
    quads: Vec<Quad>,
}

impl Candidates {
    /// The number of candidates, 2^(quadrilaterals).
    pub fn len(&self) -> usize {
        1 << self.quads.len()
    }

    /// Always false: every split or merge has candidates.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Candidate `bits`, built in full.
    pub fn get(&self, bits: usize) -> Candidate {
        Candidate {
            diagonals: self.diagonals(bits),
            edit: self.edit(bits),
            diagonal_edges: self.diagonal_edges(bits).collect(),
        }
    }

    /// The edit of candidate `bits`.
    pub fn edit(&self, bits: usize) -> PatchEdit {
        let mut edit = self.base.clone();
        edit.add_faces.reserve_exact(2 * self.quads.len());
        self.push_quad_faces(bits, &mut edit.add_faces);
        edit
    }

    /// Per quadrilateral: whether candidate `bits` takes the new diagonal.
    pub fn diagonals(&self, bits: usize) -> Vec<bool> {
        (0..self.quads.len())
            .map(|q| bits & (1 << q) != 0)
            .collect()
    }

    /// The diagonal candidate `bits` takes in each quadrilateral.
    pub fn diagonal_edges(&self, bits: usize) -> impl Iterator<Item = (Entity, Entity)> + '_ {
        self.quads.iter().enumerate().map(
            move |(q, quad)| {
                if bits & (1 << q) != 0 { quad.3 } else { quad.2 }
            },
        )
    }

    /// Appends the faces candidate `bits` adds inside the quadrilaterals.
    fn push_quad_faces(&self, bits: usize, faces: &mut Vec<[Entity; 3]>) {
        for (q, quad) in self.quads.iter().enumerate() {
            faces.extend_from_slice(if bits & (1 << q) != 0 {
                &quad.1
            } else {
                &quad.0
            });
        }
    }

    /// Rewrites `edit`, a copy of the shared edit, into candidate `bits`'s.
    fn write_edit(&self, bits: usize, edit: &mut PatchEdit) {
        edit.add_faces.truncate(self.base.add_faces.len());
        self.push_quad_faces(bits, &mut edit.add_faces);
    }
}

/// The 16 split candidates for region `r` with new vertex `n` at `position`.
pub fn split_candidates(r: &EdgeRegion, n: Entity, position: DVec3) -> Candidates {
    let [i1, i2] = r.i;
    let [j1, j2] = r.j;
    let [k1, k2, k3, k4] = r.k;
    // Per quadrilateral: (old-diagonal faces, new-diagonal faces, old and
    // new diagonal).
    let quads = vec![
        (
            [[i1, n, j1], [i1, j1, k1]],
            [[n, j1, k1], [n, k1, i1]],
            (i1, j1),
            (n, k1),
        ),
        (
            [[n, i2, j1], [j1, i2, k2]],
            [[n, i2, k2], [n, k2, j1]],
            (i2, j1),
            (n, k2),
        ),
        (
            [[i2, n, j2], [i2, j2, k3]],
            [[n, j2, k3], [n, k3, i2]],
            (i2, j2),
            (n, k3),
        ),
        (
            [[n, i1, j2], [j2, i1, k4]],
            [[n, i1, k4], [n, k4, j2]],
            (i1, j2),
            (n, k4),
        ),
    ];
    let base = PatchEdit {
        remove_faces: [r.central.as_slice(), r.outer.as_slice()].concat(),
        add_vertices: vec![(n, position)],
        ..Default::default()
    };
    Candidates { base, quads }
}

/// The 4 merge candidates: i1 survives as i at `mid`, i2 is removed.
pub fn merge_candidates(m: &Membrane, r: &EdgeRegion, mid: DVec3) -> Candidates {
    let [i, i2] = r.i;
    let [j1, j2] = r.j;
    let [k1, k2, k3, k4] = r.k;
    // Other faces of i2's fan, relabelled to i.
    let t = m.cached_topology();
    let patch: Vec<Entity> = [r.central.as_slice(), r.outer.as_slice()].concat();
    let s2 = t.slot(i2).expect("live vertex") as usize;
    let mut relabelled_remove = Vec::new();
    let mut relabelled_add = Vec::new();
    for &f in t.ring_faces_of(s2) {
        let fe = t.face_entities[f as usize];
        if patch.contains(&fe) {
            continue;
        }
        relabelled_remove.push(fe);
        let tri = t.faces[f as usize].map(|v| t.vertex_entities[v as usize]);
        relabelled_add.push(tri.map(|v| if v == i2 { i } else { v }));
    }
    let quads = vec![
        (
            [[i, j1, k1], [j1, i, k2]],
            [[k1, i, k2], [k2, j1, k1]],
            (i, j1),
            (k1, k2),
        ),
        (
            [[i, j2, k3], [j2, i, k4]],
            [[k3, i, k4], [k4, j2, k3]],
            (i, j2),
            (k3, k4),
        ),
    ];
    let base = PatchEdit {
        remove_faces: [patch.as_slice(), relabelled_remove.as_slice()].concat(),
        add_faces: relabelled_add,
        remove_vertices: vec![i2],
        move_vertices: vec![(i, mid)],
        ..Default::default()
    };
    Candidates { base, quads }
}

/// A candidate's score: (valence variance, std of the diagonal lengths).
/// The variance comes from integer sums, so it is exact up to one rounding
/// and equal for candidates whose valences are the same multiset.
fn score(valences: &ValenceSums, lengths: &[f64]) -> (f64, f64) {
    let lm = lengths.iter().sum::<f64>() / lengths.len().max(1) as f64;
    let spread = (lengths.iter().map(|l| (l - lm).powi(2)).sum::<f64>()
        / lengths.len().max(1) as f64)
        .sqrt();
    (valences.variance(), spread)
}

/// Count, sum and sum of squares of a candidate's valences after the edit.
#[derive(Default)]
struct ValenceSums {
    count: u64,
    sum: u64,
    sum_of_squares: u64,
}

impl ValenceSums {
    fn add(&mut self, valence: usize) {
        let v = valence as u64;
        self.count += 1;
        self.sum += v;
        self.sum_of_squares += v * v;
    }

    /// The population variance, (n Σv² − (Σv)²) / n² (0 for no valences).
    fn variance(&self) -> f64 {
        if self.count == 0 {
            return 0.0;
        }
        let n = self.count as f64;
        (self.count * self.sum_of_squares - self.sum * self.sum) as f64 / (n * n)
    }
}

/// Picks the valid candidate with the least valence variance (ties: most
/// uniform diagonal lengths at `position_of`; full ties: the first), or the
/// last rejection.
///
/// Every candidate is scored from its valences after the edit, which need
/// no check ([`KeptFaces`], as [`Membrane::valences_after`]); the
/// candidates are then checked best first and the first valid one is
/// taken. That is the candidate a check of every candidate would pick, for
/// one full check instead of one per candidate in the usual case. Returns
/// the candidate's `bits` (see [`Candidates`]).
pub fn choose(
    m: &Membrane,
    candidates: &Candidates,
    valence: ValenceRange,
    position_of: impl Fn(Entity) -> DVec3,
) -> Result<usize, RemeshError> {
    choose_checked(m, candidates, valence, position_of).map(|(bits, _)| bits)
}

/// Most quadrilaterals of a split or merge (a split has 4, a merge 2), so
/// at most 16 candidates.
const MAX_QUADS: usize = 4;

/// [`choose`], also returning the chosen candidate's edit, checked on `m`.
fn choose_checked(
    m: &Membrane,
    candidates: &Candidates,
    valence: ValenceRange,
    position_of: impl Fn(Entity) -> DVec3,
) -> Result<(usize, PatchEdit), RemeshError> {
    assert!(
        candidates.quads.len() <= MAX_QUADS,
        "at most {MAX_QUADS} quadrilaterals"
    );
    let base = &candidates.base;
    // The candidates remove the same faces: what each vertex keeps is
    // counted once (`None`: a face to remove is not live).
    let kept = KeptFaces::of(m, &base.remove_faces);
    let mut faces: Vec<[Entity; 3]> =
        Vec::with_capacity(base.add_faces.len() + 2 * candidates.quads.len());
    let mut lengths = [0.0; MAX_QUADS];
    let mut scores: [Option<(f64, f64)>; 1 << MAX_QUADS] = [None; 1 << MAX_QUADS];
    // Without the kept faces (a face to remove is not live) nothing is
    // scored.
    if let Some(kept) = &kept {
        for (bits, score_of) in scores.iter_mut().enumerate().take(candidates.len()) {
            faces.clear();
            faces.extend_from_slice(&base.add_faces);
            candidates.push_quad_faces(bits, &mut faces);
            let mut valences = ValenceSums::default();
            kept.for_each_valence(m, &faces, &base.remove_vertices, |_, v| valences.add(v));
            for (l, (a, b)) in lengths.iter_mut().zip(candidates.diagonal_edges(bits)) {
                *l = position_of(a).distance(position_of(b));
            }
            *score_of = Some(score(&valences, &lengths[..candidates.quads.len()]));
        }
    }
    // s beats the best so far (candidates taken in index order).
    let better = |s: (f64, f64), best: Option<(f64, f64)>| {
        best.is_none_or(|bs| s.0 < bs.0 - 1e-12 || (s.0 <= bs.0 + 1e-12 && s.1 < bs.1))
    };
    // Bit c: candidate c is not checked yet.
    let mut unchecked: u32 = (1 << candidates.len()) - 1;
    let mut last_error: Option<(usize, EditError)> = None;
    let mut edit = base.clone();
    while unchecked != 0 {
        // The best unchecked candidate; unscored ones (a face to remove is
        // not live) are checked last, only to report their error.
        let mut pick: Option<(Option<(f64, f64)>, usize)> = None;
        for c in (0..candidates.len()).filter(|&c| unchecked & (1 << c) != 0) {
            let replace = match (scores[c], pick) {
                (_, None) => true,
                (Some(s), Some((bs, _))) => better(s, bs),
                (None, Some(_)) => false,
            };
            if replace {
                pick = Some((scores[c], c));
            }
        }
        let (_, c) = pick.expect("unchecked is not empty");
        unchecked &= !(1 << c);
        candidates.write_edit(c, &mut edit);
        match m.validate_patch(&edit, valence, true) {
            Ok(_) => return Ok((c, edit)),
            Err(e) => {
                if last_error.as_ref().is_none_or(|(i, _)| c > *i) {
                    last_error = Some((c, e));
                }
            }
        }
    }
    Err(RemeshError::NoValidOption(
        last_error.map_or(EditError::BrokenFan(Entity::DANGLING), |(_, e)| e),
    ))
}

fn position(m: &Membrane, v: Entity) -> DVec3 {
    m.world
        .get::<&Position>(v)
        .map(|p| p.0)
        .unwrap_or(DVec3::NAN)
}

/// A remeshing operation on one edge. Each has a feasibility check and an
/// edit ([`EdgeOp::check_feasible`], [`EdgeOp::apply`]); statistics, events
/// and the remesh system are keyed by it, so an edge flip would be one more
/// variant with its own pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EdgeOp {
    /// Insert a vertex at the midpoint of a too-long edge.
    Split,
    /// Collapse a too-short edge into its midpoint.
    Merge,
}

impl EdgeOp {
    /// Every operation.
    pub const ALL: [EdgeOp; 2] = [EdgeOp::Split, EdgeOp::Merge];

    /// The name in outputs (`events.csv`).
    pub fn name(self) -> &'static str {
        match self {
            EdgeOp::Split => "split",
            EdgeOp::Merge => "merge",
        }
    }

    /// The operation an edge of length `l` calls for: none inside
    /// [`shorter_than`, `longer_than`], a split above, a merge otherwise.
    pub fn for_length(l: f64, shorter_than: f64, longer_than: f64) -> Option<EdgeOp> {
        if (shorter_than..=longer_than).contains(&l) {
            None
        } else if l > longer_than {
            Some(EdgeOp::Split)
        } else {
            Some(EdgeOp::Merge)
        }
    }

    /// Whether the operation is topologically possible on edge slot `edge`.
    pub fn check_feasible(
        self,
        m: &Membrane,
        edge: u32,
        valence: ValenceRange,
    ) -> Result<(), RemeshError> {
        check_feasible(m, edge, self, valence)
    }

    /// Applies the operation to edge slot `edge` (the world is unchanged on
    /// error).
    pub fn apply(
        self,
        m: &mut Membrane,
        edge: u32,
        valence: ValenceRange,
    ) -> Result<RemeshOutcome, RemeshError> {
        match self {
            EdgeOp::Split => split_edge(m, edge, valence),
            EdgeOp::Merge => merge_edge(m, edge, valence),
        }
    }
}

/// Whether `op` can be applied to edge slot `edge` at all: at
/// least one of its re-triangulations is valid with valences in range,
/// wherever the vertices are (the reference's `split.can`, checked before
/// any relaxation). Geometric validity is checked again by the edit itself.
pub fn check_feasible(
    m: &Membrane,
    edge: u32,
    op: EdgeOp,
    valence: ValenceRange,
) -> Result<(), RemeshError> {
    let r = edge_region(m, edge)?;
    // Positions do not matter to the topological check; the new vertex of a
    // split is not spawned, so a placeholder entity stands for it.
    let candidates = match op {
        EdgeOp::Split => split_candidates(&r, Entity::DANGLING, DVec3::ZERO),
        EdgeOp::Merge => merge_candidates(m, &r, DVec3::ZERO),
    };
    let mut last_error = EditError::BrokenFan(Entity::DANGLING);
    let mut edit = candidates.base.clone();
    for c in 0..candidates.len() {
        candidates.write_edit(c, &mut edit);
        match m.validate_patch(&edit, valence, false) {
            Ok(_) => return Ok(()),
            Err(e) => last_error = e,
        }
    }
    Err(RemeshError::NoValidOption(last_error))
}

/// What a split or merge did.
#[derive(Clone, Debug, PartialEq)]
pub struct RemeshOutcome {
    /// The new vertex (split) or the surviving vertex (merge).
    pub vertex: Entity,
    /// Where the event happened (midpoint of the edge, l̄).
    pub position: DVec3,
    /// Chosen diagonals per quadrilateral (`true` = new diagonal).
    pub diagonals: Vec<bool>,
}

/// Splits edge slot `edge` at its midpoint with the best valid triangulation.
/// The world is unchanged on error.
pub fn split_edge(
    m: &mut Membrane,
    edge: u32,
    valence: ValenceRange,
) -> Result<RemeshOutcome, RemeshError> {
    let r = edge_region(m, edge)?;
    let [i1, i2] = r.i;
    let mid = 0.5 * (position(m, i1) + position(m, i2));
    let values = EdgeValues::read(m, [i1, i2]);
    let n = m.reserve_vertex();
    let candidates = split_candidates(&r, n, mid);
    let pos = |v: Entity| if v == n { mid } else { position(m, v) };
    let (best, edit) = choose_checked(m, &candidates, valence, pos)?;
    m.apply_checked_patch(&edit, valence);
    values.apply_split(m, [i1, i2], n);
    Ok(RemeshOutcome {
        vertex: n,
        position: mid,
        diagonals: candidates.diagonals(best),
    })
}

/// Merges edge slot `edge`: i1 moves to the midpoint, i2 is removed, with
/// the best valid triangulation. The world is unchanged on error.
pub fn merge_edge(
    m: &mut Membrane,
    edge: u32,
    valence: ValenceRange,
) -> Result<RemeshOutcome, RemeshError> {
    let r = edge_region(m, edge)?;
    let [i1, i2] = r.i;
    let mid = 0.5 * (position(m, i1) + position(m, i2));
    let values = EdgeValues::read(m, [i1, i2]);
    let candidates = merge_candidates(m, &r, mid);
    let pos = |v: Entity| if v == i1 { mid } else { position(m, v) };
    let (best, edit) = choose_checked(m, &candidates, valence, pos)?;
    m.apply_checked_patch(&edit, valence);
    values.apply_merge(m, i1);
    Ok(RemeshOutcome {
        vertex: i1,
        position: mid,
        diagonals: candidates.diagonals(best),
    })
}

/// Counts of one operation's outcomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct OutcomeCounts {
    /// Relaxed past the goal and re-triangulated.
    pub success: u64,
    /// The edge relaxed back into the normal range: restored, nothing changed.
    pub cancel: u64,
    /// Relaxed past the goal but no valid triangulation (or a degenerate
    /// neighbourhood): restored and pushed back into range.
    pub impossible: u64,
    /// The relaxation hit its iteration cap: restored.
    pub failure: u64,
}

/// Remeshing statistics of a run.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RemeshStats {
    /// Split outcomes ([`RemeshStats::counts`] of [`EdgeOp::Split`]).
    pub split: OutcomeCounts,
    /// Merge outcomes ([`RemeshStats::counts`] of [`EdgeOp::Merge`]).
    pub merge: OutcomeCounts,
    /// Ticks that hit the per-tick event cap.
    pub overflow_ticks: u64,
    /// Ticks that ended with abnormal edges although every one was attempted.
    pub unresolved_ticks: u64,
    /// Abnormal edges left at the end of those ticks (summed).
    pub unresolved_edges: u64,
    /// Relaxation iterations spent, by phase.
    pub relax_iterations: RelaxIterations,
    /// Successful events.
    pub events: Vec<RemeshEvent>,
}

/// Relaxation iterations of a run by phase (where remeshing time goes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RelaxIterations {
    /// Pre-relaxations that reached their goal (including those whose
    /// edit then proved impossible).
    pub pre_success: u64,
    /// Pre-relaxations that ended in a cancel.
    pub pre_cancel: u64,
    /// Pre-relaxations that hit the iteration cap (1-ring and 2-ring).
    pub pre_failure: u64,
    /// Post-relaxations of new edges.
    pub post: u64,
    /// Push-backs of unsplittable/unmergeable edges.
    pub push_back: u64,
}

/// One successful split or merge.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RemeshEvent {
    /// Iteration during which it happened.
    pub iteration: u64,
    /// The operation.
    pub op: EdgeOp,
    /// Midpoint of the edge (l̄).
    pub position: [f64; 3],
}

impl RemeshStats {
    /// The outcome counts of `op`.
    pub fn counts(&self, op: EdgeOp) -> &OutcomeCounts {
        match op {
            EdgeOp::Split => &self.split,
            EdgeOp::Merge => &self.merge,
        }
    }

    /// The outcome counts of `op`, mutably.
    pub fn counts_mut(&mut self, op: EdgeOp) -> &mut OutcomeCounts {
        match op {
            EdgeOp::Split => &mut self.split,
            EdgeOp::Merge => &mut self.merge,
        }
    }

    /// Successful events of every operation.
    pub fn successes(&self) -> u64 {
        EdgeOp::ALL.iter().map(|&op| self.counts(op).success).sum()
    }

    /// σ(|r|): standard deviation of the distance of the events from the
    /// origin (paper Fig 3D), or 0 without events.
    pub fn position_spread(&self) -> f64 {
        let r: Vec<f64> = self
            .events
            .iter()
            .map(|e| DVec3::from_array(e.position).length())
            .collect();
        if r.len() < 2 {
            return 0.0;
        }
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (r.len() - 1) as f64).sqrt()
    }
}

/// The values of every registered field at an edge's two ends, read before
/// the edit that changes them.
struct EdgeValues(Vec<[f64; 2]>);

impl EdgeValues {
    /// Reads every field of `m` at `[i1, i2]`.
    fn read(m: &Membrane, [i1, i2]: [Entity; 2]) -> Self {
        Self(
            m.fields()
                .iter()
                .map(|f| [f.get(&m.world, i1), f.get(&m.world, i2)])
                .collect(),
        )
    }

    /// Applies every field's split policy: (i1, i2) became (i1, n, i2).
    fn apply_split(&self, m: &mut Membrane, [i1, i2]: [Entity; 2], n: Entity) {
        for (k, &[a, b]) in self.0.iter().enumerate() {
            let f = Arc::clone(&m.fields()[k]);
            match f.policy() {
                TransferPolicy::Conserve => {
                    f.set(&mut m.world, n, (a + b) / 3.0);
                    f.set(&mut m.world, i1, a * 2.0 / 3.0);
                    f.set(&mut m.world, i2, b * 2.0 / 3.0);
                }
                TransferPolicy::Interpolate => f.set(&mut m.world, n, 0.5 * (a + b)),
            }
        }
    }

    /// Applies every field's merge policy: (i1, i2) became `survivor`.
    fn apply_merge(&self, m: &mut Membrane, survivor: Entity) {
        for (k, &[a, b]) in self.0.iter().enumerate() {
            let f = Arc::clone(&m.fields()[k]);
            let value = match f.policy() {
                TransferPolicy::Conserve => a + b,
                TransferPolicy::Interpolate => 0.5 * (a + b),
            };
            f.set(&mut m.world, survivor, value);
        }
    }
}
