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
//! On an open mesh (issue 32) a region stops at the boundary: a boundary
//! edge has one face, so its split re-triangulates two quadrilaterals and
//! its merge one, and a quadrilateral beyond a boundary edge is just the
//! face left of it. The edit layer keeps every vertex inside or on the
//! boundary as it was and every boundary a loop, so a merge that would
//! pinch the boundary (two loops at one vertex), join two boundary
//! vertices across the interior or close a loop of three is refused. A
//! merge of an edge from the boundary inward keeps the boundary end in
//! place ([`merge_region`]).
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
use crate::mesh::topology::NO_SLOT;
use crate::mesh::vertex_field::TransferPolicy;
use glam::DVec3;
use hecs::Entity;
use std::sync::Arc;

mod candidates;
mod stats;

pub use candidates::*;
pub use stats::*;

/// The vertices and faces around an edge. On an open mesh a part beyond
/// a boundary edge is missing, [`Entity::DANGLING`]: for a boundary edge
/// (i1, i2) its second face and apex j2, with k3, k4 and their faces; for a
/// boundary edge i1–j1 (say) the far apex k1 and its face.
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

impl EdgeRegion {
    /// Whether the edge is a boundary edge (one face).
    pub fn on_boundary(&self) -> bool {
        self.j[1] == Entity::DANGLING
    }

    /// The region of the same edge run the other way, i2 → i1 (its j, k
    /// and faces relabelled); `None` for a boundary edge, whose one face
    /// fixes its direction.
    pub fn reversed(&self) -> Option<EdgeRegion> {
        if self.on_boundary() {
            return None;
        }
        let [k1, k2, k3, k4] = self.k;
        let [o1, o2, o3, o4] = self.outer;
        Some(EdgeRegion {
            i: [self.i[1], self.i[0]],
            j: [self.j[1], self.j[0]],
            k: [k3, k4, k1, k2],
            central: [self.central[1], self.central[0]],
            outer: [o3, o4, o1, o2],
        })
    }
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

/// Finds the region around edge slot `edge` of the current topology (see
/// [`EdgeRegion`] for what is missing next to a boundary).
pub fn edge_region(m: &Membrane, edge: u32) -> Result<EdgeRegion, RemeshError> {
    let t = m.cached_topology();
    let (Some(&[a, b]), Some(&[fl, fr])) =
        (t.edges.get(edge as usize), t.edge_faces.get(edge as usize))
    else {
        return Err(RemeshError::NoSuchEdge(edge));
    };
    let ent = |v: u32| {
        if v == NO_SLOT {
            Entity::DANGLING
        } else {
            t.vertex_entities[v as usize]
        }
    };
    // Apex of face f opposite the directed edge x → y.
    let apex = |f: u32, x: u32, y: u32| -> Option<u32> {
        let tri = t.faces.get(f as usize)?;
        (0..3)
            .find(|&m| tri[m] == x && tri[(m + 1) % 3] == y)
            .map(|m| tri[(m + 2) % 3])
    };
    // Face across the directed edge x → y (the one traversing y → x) and
    // its apex; (NO_SLOT, NO_SLOT) if x → y is a boundary edge.
    let across = |x: u32, y: u32| -> Option<(u32, u32)> {
        let k = t.neighbours(y as usize).iter().position(|&w| w == x)?;
        // Ring face k of y is (y, x, next): it traverses y → x.
        let f = t.ring_faces_of(y as usize)[k];
        if f == NO_SLOT {
            return Some((NO_SLOT, NO_SLOT));
        }
        Some((f, apex(f, y, x)?))
    };
    let j1 = apex(fl, a, b).ok_or(RemeshError::DegenerateRegion)?;
    let j2 = if fr == NO_SLOT {
        NO_SLOT
    } else {
        apex(fr, b, a).ok_or(RemeshError::DegenerateRegion)?
    };
    if j1 == j2 {
        return Err(RemeshError::DegenerateRegion);
    }
    // Outer faces: (i1, j1, k1) traverses i1 → j1, i.e. the face across j1 → i1.
    let (o1, k1) = across(j1, a).ok_or(RemeshError::DegenerateRegion)?;
    let (o2, k2) = across(b, j1).ok_or(RemeshError::DegenerateRegion)?;
    let ((o3, k3), (o4, k4)) = if j2 == NO_SLOT {
        ((NO_SLOT, NO_SLOT), (NO_SLOT, NO_SLOT))
    } else {
        (
            across(j2, b).ok_or(RemeshError::DegenerateRegion)?,
            across(a, j2).ok_or(RemeshError::DegenerateRegion)?,
        )
    };
    let ks = [k1, k2, k3, k4];
    let faces = [fl, fr, o1, o2, o3, o4];
    let distinct = faces
        .iter()
        .enumerate()
        .all(|(x, f)| *f == NO_SLOT || !faces[..x].contains(f));
    if !distinct || ks.iter().any(|k| *k != NO_SLOT && [a, b].contains(k)) {
        return Err(RemeshError::DegenerateRegion);
    }
    let fe = |f: u32| {
        if f == NO_SLOT {
            Entity::DANGLING
        } else {
            t.face_entities[f as usize]
        }
    };
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
    // Positions do not matter to the topological check; the new vertex of a
    // split is not spawned, so a placeholder entity stands for it.
    let candidates = match op {
        EdgeOp::Split => split_candidates(&edge_region(m, edge)?, Entity::DANGLING, DVec3::ZERO),
        EdgeOp::Merge => merge_candidates(m, &merge_region(m, edge)?.0, DVec3::ZERO),
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
/// the best valid triangulation; on an edge from the boundary inward the
/// boundary end survives in place ([`merge_region`]). The world is
/// unchanged on error.
pub fn merge_edge(
    m: &mut Membrane,
    edge: u32,
    valence: ValenceRange,
) -> Result<RemeshOutcome, RemeshError> {
    let (r, at) = merge_region(m, edge)?;
    let [i1, i2] = r.i;
    let values = EdgeValues::read(m, [i1, i2]);
    let candidates = merge_candidates(m, &r, at);
    let pos = |v: Entity| if v == i1 { at } else { position(m, v) };
    let (best, edit) = choose_checked(m, &candidates, valence, pos)?;
    m.apply_checked_patch(&edit, valence);
    values.apply_merge(m, i1);
    Ok(RemeshOutcome {
        vertex: i1,
        position: at,
        diagonals: candidates.diagonals(best),
    })
}

/// The region of a merge of edge slot `edge`, its survivor first, and
/// where the survivor goes: the midpoint, except on an edge from the
/// boundary inward, whose boundary end survives in place (the rim keeps
/// its shape; a merge never moves a boundary vertex off the boundary).
pub fn merge_region(m: &Membrane, edge: u32) -> Result<(EdgeRegion, DVec3), RemeshError> {
    let r = edge_region(m, edge)?;
    let t = m.cached_topology();
    let on_boundary = |v: Entity| {
        t.vertex_slot(v)
            .is_some_and(|s| t.is_boundary_vertex(s as usize))
    };
    let [a, b] = r.i.map(on_boundary);
    let r = match (a, b, r.reversed()) {
        (false, true, Some(reversed)) => reversed,
        _ => r,
    };
    let [i1, i2] = r.i;
    let at = if a != b {
        position(m, i1)
    } else {
        0.5 * (position(m, i1) + position(m, i2))
    };
    Ok((r, at))
}
