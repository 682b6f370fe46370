//! The mesh-edit layer: every topology change goes through
//! [`Membrane::apply_patch`], which checks a proposed patch completely
//! before touching the world (check-then-act).
//!
//! Contract of a [`PatchEdit`]:
//! - `remove_faces` are despawned; `add_faces` (vertex entities, counter-
//!   clockwise from outside) are spawned as new face entities;
//! - `add_vertices` are spawned (their entities come from
//!   [`Membrane::reserve_vertex`]); `remove_vertices` are despawned and must
//!   be used by no remaining or new face; `move_vertices` get new positions;
//! - an edge entity whose two vertices still share faces is **reused**
//!   (its `faces` refreshed); an edge left without faces is despawned; an
//!   edge that did not exist is spawned;
//! - after the edit every affected edge has exactly one face on each side
//!   (on an open mesh, a boundary edge has one: an edge on a boundary stays
//!   there, an interior one stays inside, a new one-face edge joins two
//!   boundary vertices; its missing face is [`Entity::DANGLING`]), every
//!   affected vertex has a single fan, closed inside or open on a boundary
//!   as it was before (a new vertex either), with a valence in range
//!   ([`ValenceRange::for_boundary`] on a boundary), and no new face is
//!   degenerate or folded over against the patch it replaces (on an open
//!   mesh, neither is a kept face of a moved vertex).
//!
//! A patch that would break any of these is rejected with an [`EditError`]
//! and the world is unchanged. A successful edit updates the topology
//! cache for its patch only ([`crate::mesh::topology_update`]).

mod check;
mod density_transfer;

use crate::mesh::ValenceRange;
use crate::mesh::components::{Edge, Face, Force, Position};
use crate::mesh::membrane::Membrane;
use crate::mesh::topology::NO_SLOT;
use crate::mesh::topology_update::WorldChange;
use glam::DVec3;
use hecs::Entity;
// Entity keys are not attacker-controlled: a fast non-cryptographic hash.
use rustc_hash::FxHashMap as HashMap;

/// A proposed topology change (see the module contract).
#[derive(Clone, Debug, Default)]
pub struct PatchEdit {
    /// Face entities to remove.
    pub remove_faces: Vec<Entity>,
    /// Faces to add, as vertex entities counter-clockwise from outside.
    pub add_faces: Vec<[Entity; 3]>,
    /// New vertices: reserved entity and position (they get every
    /// registered per-vertex field; see [`crate::mesh::vertex_field`]).
    pub add_vertices: Vec<(Entity, DVec3)>,
    /// Vertex entities to remove.
    pub remove_vertices: Vec<Entity>,
    /// Existing vertices moved by the edit (e.g. a merge's midpoint).
    pub move_vertices: Vec<(Entity, DVec3)>,
}

/// A new face with 2·area / (longest edge)² below this is degenerate (a
/// sliver with an angle below ≈ 1e-4 degrees).
pub const MIN_FACE_SHAPE: f64 = 1e-6;

/// Why a patch was rejected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EditError {
    /// A face to remove is not a live face.
    #[error("face {0:?} is not a live face")]
    UnknownFace(Entity),
    /// A new face repeats a vertex.
    #[error("new face {0:?} repeats a vertex")]
    DegenerateFace([Entity; 3]),
    /// An edge would not have exactly one face per side.
    #[error("edge {a:?}-{b:?} would have {forward} faces one way and {backward} the other")]
    EdgeFaces {
        /// First vertex.
        a: Entity,
        /// Second vertex.
        b: Entity,
        /// Faces traversing a → b.
        forward: usize,
        /// Faces traversing b → a.
        backward: usize,
    },
    /// A vertex's faces would not form one closed fan.
    #[error("vertex {0:?} would not have a single closed fan of faces")]
    BrokenFan(Entity),
    /// A vertex would leave the valence range.
    #[error("vertex {vertex:?} would have valence {valence}")]
    Valence {
        /// The vertex.
        vertex: Entity,
        /// Its valence after the edit.
        valence: usize,
    },
    /// A vertex to remove would still be used.
    #[error("vertex {0:?} is removed but still used by a face")]
    VertexStillUsed(Entity),
    /// A new face would be (nearly) degenerate.
    #[error("new face {0:?} would be degenerate")]
    DegenerateGeometry([Entity; 3]),
    /// A new face would point against the surface it replaces.
    #[error("new face {0:?} would fold over")]
    FoldOver([Entity; 3]),
}

/// A face entity with its vertex entities.
type FaceRef = (Entity, [Entity; 3]);

/// Result of a successful edit.
#[derive(Clone, Debug, Default)]
pub struct EditOutcome {
    /// New face entities, in `add_faces` order.
    pub faces: Vec<Entity>,
    /// Edge entities spawned.
    pub edges_created: usize,
    /// Edge entities despawned.
    pub edges_removed: usize,
}

impl Membrane {
    /// Reserves an entity for a vertex that a [`PatchEdit`] will add.
    pub fn reserve_vertex(&self) -> Entity {
        self.world.reserve_entity()
    }

    /// The valence of every affected vertex after `edit`, without checking
    /// it: the number of faces around the vertex once the removed faces are
    /// gone and the added ones are in (vertices the edit removes are left
    /// out). For an edit that [`Membrane::check_patch`] accepts these are
    /// the valences it returns, in the same map; `None` if a face to remove
    /// is not live.
    pub fn valences_after(&self, edit: &PatchEdit) -> Option<HashMap<Entity, usize>> {
        let mut valences = HashMap::default();
        KeptFaces::of(self, &edit.remove_faces)?.for_each_valence(
            self,
            &edit.add_faces,
            &edit.remove_vertices,
            |v, n, _| {
                valences.insert(v, n);
            },
        );
        Some(valences)
    }

    /// Checks `edit` and, if valid, applies it to the world (see the module
    /// contract). The topology cache is updated for the patch before returning.
    pub fn apply_patch(
        &mut self,
        edit: &PatchEdit,
        valence: ValenceRange,
    ) -> Result<EditOutcome, EditError> {
        self.topology()
            .expect("the topology was valid before the edit");
        self.validate_patch(edit, valence, true)?;
        Ok(self.apply_checked_patch(edit, valence))
    }

    /// [`Membrane::apply_patch`] for an edit that [`Membrane::check_patch`]
    /// has just accepted, with the same valence range, on this world
    /// unchanged since: it is applied without a second check (debug builds
    /// check it again).
    pub(crate) fn apply_checked_patch(
        &mut self,
        edit: &PatchEdit,
        valence: ValenceRange,
    ) -> EditOutcome {
        debug_assert!(
            self.validate_patch(edit, valence, true).is_ok(),
            "an edit applied as checked fails its check"
        );
        let densities = density_transfer::DensitySnapshot::before(self, edit);
        let (keys, edge_entity) = self.patch_edges(edit);
        let new_face_entities: Vec<Entity> = edit
            .add_faces
            .iter()
            .map(|_| self.world.reserve_entity())
            .collect();
        let faces_after = self.faces_after_by_edge(edit, &keys, &new_face_entities);

        // Act, recording each change for the topology update.
        let mut changes =
            Vec::with_capacity(2 * (edit.remove_faces.len() + edit.add_faces.len()) + keys.len());
        for &f in &edit.remove_faces {
            if self.world.despawn(f).is_ok() {
                changes.push(WorldChange::DespawnFace(f));
            }
        }
        self.spawn_added_vertices(edit, &mut changes);
        let mut outcome = EditOutcome {
            faces: new_face_entities.clone(),
            ..Default::default()
        };
        let final_edge = self.write_patch_edges(
            &keys,
            &edge_entity,
            &faces_after,
            &mut outcome,
            &mut changes,
        );
        self.spawn_added_faces(edit, &new_face_entities, &final_edge, &mut changes);
        for &v in &edit.remove_vertices {
            if self.world.despawn(v).is_ok() {
                changes.push(WorldChange::DespawnVertex(v));
            }
        }
        for &(v, p) in &edit.move_vertices {
            if let Ok(mut pos) = self.world.get::<&mut Position>(v) {
                pos.0 = p;
            }
        }
        self.update_topology(&changes)
            .expect("a checked edit keeps the topology valid");
        if let Some(d) = densities {
            d.transfer(self, edit);
        }
        outcome
    }

    /// The affected undirected edges of `edit` (every edge of a removed or
    /// added face, in first-seen order) and the current entities of those
    /// that exist.
    fn patch_edges(&self, edit: &PatchEdit) -> (Vec<EdgeKey>, EdgeMap) {
        let t = self.cached_topology();
        let mut edge_entity = EdgeMap::with_capacity(16);
        // Room for a patch's edges: 17 to 21 for a split, as many for a merge.
        let mut keys: Vec<EdgeKey> = Vec::with_capacity(32);
        let note = |a: Entity, b: Entity, keys: &mut Vec<EdgeKey>| {
            let k = edge_key(a, b);
            if !keys.contains(&k) {
                keys.push(k);
            }
        };
        for &f in &edit.remove_faces {
            let s = t.slot(f).expect("checked") as usize;
            let tri = t.faces[s].map(|v| t.vertex_entities[v as usize]);
            for m in 0..3 {
                let e = t.edge_entities[t.face_edges[s][m] as usize];
                edge_entity.set(edge_key(tri[m], tri[(m + 1) % 3]), e);
                note(tri[m], tri[(m + 1) % 3], &mut keys);
            }
        }
        for tri in &edit.add_faces {
            for m in 0..3 {
                note(tri[m], tri[(m + 1) % 3], &mut keys);
            }
        }
        // Existing edges between affected vertices that no removed face
        // touches (e.g. an edge that a new face reuses).
        for &(a, b) in &keys {
            if edge_entity.get((a, b)).is_some() {
                continue;
            }
            let slots = t.vertex_slot(a).zip(t.vertex_slot(b));
            if let Some(e) = slots.and_then(|(sa, sb)| t.edge_between(sa, sb)) {
                edge_entity.set((a, b), t.edge_entities[e as usize]);
            }
        }
        (keys, edge_entity)
    }

    /// The faces of each edge of `keys` after `edit`, whose new faces get
    /// `new_face_entities`.
    fn faces_after_by_edge(
        &self,
        edit: &PatchEdit,
        keys: &[EdgeKey],
        new_face_entities: &[Entity],
    ) -> EdgeFaces {
        let t = self.cached_topology();
        let removed = &edit.remove_faces;
        let mut faces_after: Vec<FaceRef> = Vec::with_capacity(2 * keys.len());
        let mut ranges: Vec<(usize, usize)> = Vec::with_capacity(keys.len());
        for &(a, b) in keys {
            let start = faces_after.len();
            if let Some(slot) = t.vertex_slot(a) {
                for &f in t.ring_faces_of(slot as usize) {
                    if f == NO_SLOT {
                        continue; // a boundary vertex's open end
                    }
                    let e = t.face_entities[f as usize];
                    let tri = t.faces[f as usize].map(|s| t.vertex_entities[s as usize]);
                    if !removed.contains(&e) && tri.contains(&b) {
                        faces_after.push((e, tri));
                    }
                }
            }
            for (i, f) in edit.add_faces.iter().enumerate() {
                if f.contains(&a) && f.contains(&b) {
                    faces_after.push((new_face_entities[i], *f));
                }
            }
            ranges.push((start, faces_after.len()));
        }
        EdgeFaces {
            faces: faces_after,
            ranges,
        }
    }

    /// Spawns `edit`'s new vertices, each with every registered per-vertex
    /// field's component in one spawn (values are set by the fields'
    /// transfer policies afterwards).
    fn spawn_added_vertices(&mut self, edit: &PatchEdit, changes: &mut Vec<WorldChange>) {
        for &(v, p) in &edit.add_vertices {
            let mut vertex = hecs::EntityBuilder::new();
            vertex.add(Position(p)).add(Force::default());
            for field in self.fields() {
                field.add_to(&mut vertex);
            }
            self.world.spawn_at(v, vertex.build());
            changes.push(WorldChange::SpawnVertex(v));
        }
    }

    /// Gives every edge of `keys` its faces after the edit (`faces_after`):
    /// an edge left without faces is despawned, an existing one (in
    /// `existing`) is rewritten, a new one is spawned. Returns the edge
    /// entities after the edit.
    fn write_patch_edges(
        &mut self,
        keys: &[EdgeKey],
        existing: &EdgeMap,
        faces_after: &EdgeFaces,
        outcome: &mut EditOutcome,
        changes: &mut Vec<WorldChange>,
    ) -> EdgeMap {
        let mut final_edge = EdgeMap::with_capacity(keys.len());
        for (&(a, b), &(start, end)) in keys.iter().zip(&faces_after.ranges) {
            let list = &faces_after.faces[start..end];
            let existing = existing.get((a, b));
            if list.is_empty() {
                if let Some(e) = existing
                    && self.world.despawn(e).is_ok()
                {
                    changes.push(WorldChange::DespawnEdge(e));
                    outcome.edges_removed += 1;
                }
                continue;
            }
            let (vertices, faces) = edge_sides(a, b, list);
            let edge = Edge { vertices, faces };
            let e = match existing {
                Some(e) => {
                    if let Ok(mut c) = self.world.get::<&mut Edge>(e) {
                        *c = edge;
                    }
                    changes.push(WorldChange::UpdateEdge(e));
                    e
                }
                None => {
                    outcome.edges_created += 1;
                    let e = self.world.spawn((edge,));
                    changes.push(WorldChange::SpawnEdge(e));
                    e
                }
            };
            final_edge.set((a, b), e);
        }
        final_edge
    }

    /// Spawns `edit`'s new faces as `new_face_entities`, with their edges
    /// from `edges` (the edge entities after the edit).
    fn spawn_added_faces(
        &mut self,
        edit: &PatchEdit,
        new_face_entities: &[Entity],
        edges: &EdgeMap,
        changes: &mut Vec<WorldChange>,
    ) {
        for (i, tri) in edit.add_faces.iter().enumerate() {
            let face_edges = [0, 1, 2].map(|m| {
                edges
                    .get(edge_key(tri[m], tri[(m + 1) % 3]))
                    .expect("an edge of a new face")
            });
            self.world.spawn_at(
                new_face_entities[i],
                (Face {
                    vertices: *tri,
                    edges: face_edges,
                },),
            );
            changes.push(WorldChange::SpawnFace(new_face_entities[i]));
        }
    }
}

/// An undirected edge as its two vertex entities, in `edge_key` order.
type EdgeKey = (Entity, Entity);

/// The key of the undirected edge `a`-`b`: the smaller entity first.
#[inline]
fn edge_key(a: Entity, b: Entity) -> EdgeKey {
    if a.to_bits() < b.to_bits() {
        (a, b)
    } else {
        (b, a)
    }
}

/// A small map of a patch's edges to their entities, searched linearly
/// (see the `check` module).
struct EdgeMap(Vec<(EdgeKey, Entity)>);

impl EdgeMap {
    /// An empty map with room for `n` edges.
    fn with_capacity(n: usize) -> Self {
        Self(Vec::with_capacity(n))
    }

    /// Sets the entity of edge `k`.
    #[inline]
    fn set(&mut self, k: EdgeKey, e: Entity) {
        match self.0.iter_mut().find(|(key, _)| *key == k) {
            Some(entry) => entry.1 = e,
            None => self.0.push((k, e)),
        }
    }

    /// The entity of edge `k`, if set.
    #[inline]
    fn get(&self, k: EdgeKey) -> Option<Entity> {
        self.0.iter().find(|(key, _)| *key == k).map(|&(_, e)| e)
    }
}

/// The faces of a patch's edges after an edit.
struct EdgeFaces {
    /// `faces[ranges[i].0..ranges[i].1]` are the faces of the `i`-th edge.
    faces: Vec<FaceRef>,
    /// Ranges into `faces`, one per edge.
    ranges: Vec<(usize, usize)>,
}

/// The vertices and the faces on the two sides of edge `a`-`b` among its
/// faces after the edit (`list`): `[a, b]` with the face traversing a → b,
/// then the one traversing b → a. A boundary edge (one face) runs the way
/// its face traverses it, and its missing face is [`Entity::DANGLING`].
#[inline]
fn edge_sides(a: Entity, b: Entity, list: &[FaceRef]) -> ([Entity; 2], [Entity; 2]) {
    let left = list
        .iter()
        .find(|(_, f)| (0..3).any(|m| f[m] == a && f[(m + 1) % 3] == b));
    let right = list
        .iter()
        .find(|(_, f)| (0..3).any(|m| f[m] == b && f[(m + 1) % 3] == a));
    match (left, right) {
        (Some(left), Some(right)) => ([a, b], [left.0, right.0]),
        (Some(left), None) => ([a, b], [left.0, Entity::DANGLING]),
        (None, Some(right)) => ([b, a], [right.0, Entity::DANGLING]),
        (None, None) => unreachable!("checked: an edge kept has a face"),
    }
}

/// How many of its faces each vertex keeps when a set of faces is removed:
/// the part of the valences after an edit that all candidate edits
/// removing the same faces share (a split's 16 candidates, a merge's 4).
/// [`KeptFaces::for_each_valence`] adds each candidate's new faces.
pub struct KeptFaces {
    remove_faces: Vec<Entity>,
    /// Every vertex of a removed face, in first-seen order, with the
    /// number of its faces that are not removed.
    kept: Vec<(Entity, usize)>,
}

impl KeptFaces {
    /// For removing `remove_faces` from the current topology; `None` if
    /// one is not a live face.
    pub fn of(m: &Membrane, remove_faces: &[Entity]) -> Option<Self> {
        let t = m.cached_topology();
        let mut kept: Vec<(Entity, usize)> = Vec::with_capacity(2 * remove_faces.len() + 4);
        for &f in remove_faces {
            for s in t.faces[t.face_slot(f)? as usize] {
                let v = t.vertex_entities[s as usize];
                if !kept.iter().any(|&(x, _)| x == v) {
                    kept.push((v, kept_count(m, s, remove_faces)));
                }
            }
        }
        Some(Self {
            remove_faces: remove_faces.to_vec(),
            kept,
        })
    }

    /// Calls `visit(v, valence after the edit, on a boundary)` for every
    /// vertex of a face that an edit removing these counts' faces removes
    /// or adds (`add_faces`), once each in first-seen order (removed faces
    /// first), except the vertices it removes (`remove_vertices`). A
    /// vertex's valence after the edit is its faces (one per neighbour in a
    /// closed fan, one fewer in an open one): the faces it keeps plus the
    /// added faces that use it, plus one on a boundary. A vertex stays on
    /// the boundary or inside (the edit layer refuses anything else); a new
    /// vertex is on a boundary if its new faces form an open fan.
    pub fn for_each_valence(
        &self,
        m: &Membrane,
        add_faces: &[[Entity; 3]],
        remove_vertices: &[Entity],
        mut visit: impl FnMut(Entity, usize, bool),
    ) {
        let t = m.cached_topology();
        let added = |v: Entity| add_faces.iter().filter(|f| f.contains(&v)).count();
        let open = |v: Entity| match t.vertex_slot(v) {
            Some(s) => t.is_boundary_vertex(s as usize),
            None => opens_a_fan(v, add_faces),
        };
        let mut visit = |v: Entity, faces: usize| {
            let open = open(v);
            visit(v, faces + usize::from(open), open);
        };
        for &(v, kept) in &self.kept {
            if !remove_vertices.contains(&v) {
                visit(v, kept + added(v));
            }
        }
        let corners = || add_faces.iter().flatten();
        for (i, &v) in corners().enumerate() {
            let seen = self.kept.iter().any(|&(x, _)| x == v) || corners().take(i).any(|&x| x == v);
            if seen || remove_vertices.contains(&v) {
                continue;
            }
            let kept = t
                .vertex_slot(v)
                .map_or(0, |s| kept_count(m, s, &self.remove_faces));
            visit(v, kept + added(v));
        }
    }
}

/// The faces of vertex slot `s` that are not in `remove_faces`.
fn kept_count(m: &Membrane, s: u32, remove_faces: &[Entity]) -> usize {
    let t = m.cached_topology();
    t.ring_faces_of(s as usize)
        .iter()
        .filter(|&&f| f != NO_SLOT && !remove_faces.contains(&t.face_entities[f as usize]))
        .count()
}

/// Whether the faces of `faces` around the new vertex `v` leave its fan
/// open: a face (v, a, b) with no face (v, x, a) before it.
fn opens_a_fan(v: Entity, faces: &[[Entity; 3]]) -> bool {
    let step = |f: &[Entity; 3]| {
        let k = f.iter().position(|&x| x == v)?;
        Some((f[(k + 1) % 3], f[(k + 2) % 3]))
    };
    faces
        .iter()
        .filter_map(step)
        .any(|(a, _)| !faces.iter().filter_map(step).any(|(_, b)| b == a))
}
