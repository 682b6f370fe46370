//! Updating the topology cache after one edit in O(patch) instead of
//! rebuilding it from the whole world.
//!
//! The edit layer ([`crate::edit`]) records every spawn, despawn and edge
//! refresh it makes, in order ([`WorldChange`]). Dense slots follow the
//! world's storage order: hecs appends a spawned entity to its archetype
//! and fills a despawned entity's place with the archetype's last entity
//! (swap-remove). [`Topology::apply_edit`] replays those moves on the slot
//! arrays, then recomputes only what refers to a touched or moved item:
//! the faces' corners and edges, the edges' ends and faces, and the ring
//! blocks of the vertices around them. The result is what
//! [`Topology::build`] would give for the edited world; tests and debug
//! builds check that after every edit.

use crate::components::{Edge, Face};
use crate::topology::{NO_SLOT, Topology, TopologyError};
use hecs::{Entity, World};

/// One change the edit layer made to the world, in the order it made it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WorldChange {
    /// A face entity was despawned.
    DespawnFace(Entity),
    /// A face entity was spawned.
    SpawnFace(Entity),
    /// A vertex entity was spawned.
    SpawnVertex(Entity),
    /// A vertex entity was despawned.
    DespawnVertex(Entity),
    /// An edge entity was spawned.
    SpawnEdge(Entity),
    /// An existing edge entity's [`Edge`] component was rewritten.
    UpdateEdge(Entity),
    /// An edge entity was despawned.
    DespawnEdge(Entity),
}

/// Why an edit could not be applied incrementally (the caller rebuilds).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum UpdateError {
    /// The edited world is not a valid closed triangulation.
    #[error(transparent)]
    Topology(#[from] TopologyError),
    /// A vertex's valence outgrew its ring block.
    #[error("vertex slot {0} outgrew its ring block")]
    RingOverflow(u32),
    /// A change names an entity the cache does not know.
    #[error("the edit names {0:?}, which the cache does not know")]
    Unknown(Entity),
}

/// Which dense list an entity lives in.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Vertex,
    Edge,
    Face,
}

/// A dense entity list as it will be after the changes, simulated on top
/// of the unchanged cache: only the slots the changes touch are stored.
struct Simulated<'a> {
    base: &'a [Entity],
    len: usize,
    changed: Vec<(usize, Entity)>,
    /// Entities whose slot changed (moved into a hole).
    moved: Vec<Entity>,
}

impl<'a> Simulated<'a> {
    fn new(base: &'a [Entity]) -> Self {
        Self {
            base,
            len: base.len(),
            changed: Vec::new(),
            moved: Vec::new(),
        }
    }

    fn at(&self, slot: usize) -> Entity {
        self.changed
            .iter()
            .rev()
            .find(|(s, _)| *s == slot)
            .map_or_else(|| self.base[slot], |(_, e)| *e)
    }

    fn slot(&self, e: Entity, base_slot: Option<usize>) -> Option<usize> {
        // The latest assignment wins; an entity not reassigned keeps its base slot.
        match self.changed.iter().rev().find(|(_, x)| *x == e) {
            Some(&(s, _)) => (s < self.len && self.at(s) == e).then_some(s),
            None => base_slot.filter(|&s| s < self.len && self.at(s) == e),
        }
    }

    fn remove(&mut self, slot: usize) {
        let last = self.len - 1;
        let m = self.at(last);
        self.len -= 1;
        if slot != last {
            self.changed.push((slot, m));
            if !self.moved.contains(&m) {
                self.moved.push(m);
            }
        }
    }

    fn push(&mut self, e: Entity) {
        self.changed.push((self.len, e));
        self.len += 1;
    }
}

/// Pushes `x` unless present (the sets here hold a patch's few items).
fn insert(set: &mut Vec<Entity>, x: Entity) {
    if !set.contains(&x) {
        set.push(x);
    }
}

impl Topology {
    /// Updates the cache for the world after `changes` (see the module
    /// docs), setting `epoch`. On error the cache is unusable and the caller
    /// rebuilds it with [`Topology::build`].
    pub fn apply_edit(
        &mut self,
        world: &World,
        changes: &[WorldChange],
        epoch: u64,
    ) -> Result<(), UpdateError> {
        // 1. Which entities move, from the unchanged cache.
        let mut vertices = Simulated::new(&self.vertex_entities);
        let mut edges = Simulated::new(&self.edge_entities);
        let mut faces = Simulated::new(&self.face_entities);
        let base_slot = |e: Entity, list: &[Entity]| {
            self.slot(e)
                .map(|s| s as usize)
                .filter(|&s| list.get(s) == Some(&e))
        };
        let mut removed_faces = Vec::new();
        let mut added_faces = Vec::new();
        // Vertices whose ring is rewritten, and faces/edges recomputed.
        let mut ring_dirty: Vec<Entity> = Vec::new();
        let mut face_dirty: Vec<Entity> = Vec::new();
        let mut edge_dirty: Vec<Entity> = Vec::new();
        for &c in changes {
            let (list, e, spawn) = match c {
                WorldChange::DespawnFace(e) => (&mut faces, e, false),
                WorldChange::SpawnFace(e) => (&mut faces, e, true),
                WorldChange::SpawnVertex(e) => (&mut vertices, e, true),
                WorldChange::DespawnVertex(e) => (&mut vertices, e, false),
                WorldChange::SpawnEdge(e) => (&mut edges, e, true),
                WorldChange::DespawnEdge(e) => (&mut edges, e, false),
                WorldChange::UpdateEdge(e) => {
                    insert(&mut edge_dirty, e);
                    continue;
                }
            };
            if spawn {
                list.push(e);
                continue;
            }
            let s = list
                .slot(e, base_slot(e, list.base))
                .ok_or(UpdateError::Unknown(e))?;
            list.remove(s);
        }
        for &c in changes {
            match c {
                WorldChange::DespawnFace(f) => {
                    removed_faces.push(f);
                    // Its corners lose a face.
                    let s = self.face_slot(f).ok_or(UpdateError::Unknown(f))? as usize;
                    for v in self.faces[s] {
                        insert(&mut ring_dirty, self.vertex_entities[v as usize]);
                    }
                }
                WorldChange::SpawnFace(f) => {
                    added_faces.push(f);
                    insert(&mut face_dirty, f);
                }
                WorldChange::SpawnEdge(e) => insert(&mut edge_dirty, e),
                _ => {}
            }
        }
        let face_of = |f: Entity| -> Result<Face, UpdateError> {
            world
                .get::<&Face>(f)
                .map(|c| *c)
                .map_err(|_| UpdateError::Unknown(f))
        };
        let edge_of = |e: Entity| -> Result<Edge, UpdateError> {
            world
                .get::<&Edge>(e)
                .map(|c| *c)
                .map_err(|_| UpdateError::Unknown(e))
        };
        for &f in &added_faces {
            for v in face_of(f)?.vertices {
                insert(&mut ring_dirty, v);
            }
        }
        // Incident faces (entities) of a vertex after the edit: the cached
        // ring's faces, less the removed ones, plus the added ones using it.
        let incident = |v: Entity| -> Result<Vec<Entity>, UpdateError> {
            let mut list: Vec<Entity> = match base_slot(v, &self.vertex_entities) {
                Some(s) => self
                    .ring_faces_of(s)
                    .iter()
                    .map(|&f| self.face_entities[f as usize])
                    .filter(|f| !removed_faces.contains(f))
                    .collect(),
                None => Vec::new(),
            };
            for &f in &added_faces {
                if face_of(f)?.vertices.contains(&v) {
                    list.push(f);
                }
            }
            Ok(list)
        };
        // A moved vertex: its faces and edges name its slot, and so do its
        // neighbours' rings.
        // (An entity moved by one removal may itself be removed later.)
        let alive = |e: &&Entity| world.contains(**e);
        // A recomputed face, and the rings of its corners and its edges.
        let mark_face = |f: Entity,
                         face_dirty: &mut Vec<Entity>,
                         ring_dirty: &mut Vec<Entity>,
                         edge_dirty: &mut Vec<Entity>|
         -> Result<(), UpdateError> {
            insert(face_dirty, f);
            let face = face_of(f)?;
            for k in 0..3 {
                insert(ring_dirty, face.vertices[k]);
                insert(edge_dirty, face.edges[k]);
            }
            Ok(())
        };
        for &x in vertices.moved.iter().filter(alive) {
            insert(&mut ring_dirty, x);
            for f in incident(x)? {
                mark_face(f, &mut face_dirty, &mut ring_dirty, &mut edge_dirty)?;
            }
        }
        // A moved face: its edges and its corners' rings name its slot.
        for &f in faces.moved.iter().filter(alive) {
            mark_face(f, &mut face_dirty, &mut ring_dirty, &mut edge_dirty)?;
        }
        // A moved edge: its faces and its ends' rings name its slot.
        for &e in edges.moved.iter().filter(alive) {
            insert(&mut edge_dirty, e);
            let edge = edge_of(e)?;
            for f in edge.faces {
                insert(&mut face_dirty, f);
            }
            for v in edge.vertices {
                insert(&mut ring_dirty, v);
            }
        }
        // The new incident face sets, while the cache is still the old one.
        let mut fans: Vec<(Entity, Vec<Entity>)> = Vec::with_capacity(ring_dirty.len());
        for &v in &ring_dirty {
            if world.contains(v) && world.get::<&crate::components::Position>(v).is_ok() {
                fans.push((v, incident(v)?));
            }
        }

        // 2. Replay the moves on the dense arrays.
        for &c in changes {
            match c {
                WorldChange::DespawnFace(e) => self.remove_slot(Kind::Face, e)?,
                WorldChange::SpawnFace(e) => self.push_slot(Kind::Face, e),
                WorldChange::SpawnVertex(e) => self.push_slot(Kind::Vertex, e),
                WorldChange::DespawnVertex(e) => self.remove_slot(Kind::Vertex, e)?,
                WorldChange::SpawnEdge(e) => self.push_slot(Kind::Edge, e),
                WorldChange::DespawnEdge(e) => self.remove_slot(Kind::Edge, e)?,
                WorldChange::UpdateEdge(_) => {}
            }
        }

        // 3. Recompute what names a touched or moved slot.
        let vertex_slot = |t: &Topology, v: Entity| t.vertex_slot(v).ok_or(UpdateError::Unknown(v));
        for &f in &face_dirty {
            let Some(s) = self.face_slot(f) else {
                continue;
            };
            let face = face_of(f)?;
            let mut corners = [0u32; 3];
            let mut face_edges = [0u32; 3];
            for k in 0..3 {
                corners[k] = vertex_slot(self, face.vertices[k])?;
                let e = face.edges[k];
                face_edges[k] = self.edge_slot(e).ok_or(UpdateError::Unknown(e))?;
            }
            self.faces[s as usize] = corners;
            self.face_edges[s as usize] = face_edges;
        }
        for &e in &edge_dirty {
            let Some(s) = self.edge_slot(e) else {
                continue;
            };
            let edge = edge_of(e)?;
            self.edges[s as usize] = [
                vertex_slot(self, edge.vertices[0])?,
                vertex_slot(self, edge.vertices[1])?,
            ];
            self.edge_faces[s as usize] = edge.faces.map(|f| self.face_slot(f).unwrap_or(NO_SLOT));
        }
        let mut fan: Vec<u32> = Vec::new();
        for (v, faces_of_v) in &fans {
            let s = vertex_slot(self, *v)? as usize;
            fan.clear();
            for f in faces_of_v {
                fan.push(self.slot(*f).ok_or(UpdateError::Unknown(*f))?);
            }
            fan.sort_unstable();
            if fan.len() > self.ring_stride {
                return Err(UpdateError::RingOverflow(s as u32));
            }
            self.write_ring(s, &fan)?;
        }
        self.epoch = epoch;
        Ok(())
    }

    /// Appends `e` to its dense list (a spawn), growing the per-slot arrays.
    fn push_slot(&mut self, kind: Kind, e: Entity) {
        let id = e.id() as usize;
        if id >= self.slot_of.len() {
            self.slot_of.resize(id + 1, NO_SLOT);
        }
        match kind {
            Kind::Vertex => {
                self.slot_of[id] = self.vertex_entities.len() as u32;
                self.vertex_entities.push(e);
                self.ring_len.push(0);
                let new_len = self.ring.len() + self.ring_stride;
                self.ring.resize(new_len, 0);
                self.ring_edges.resize(new_len, 0);
                self.ring_faces.resize(new_len, 0);
            }
            Kind::Edge => {
                self.slot_of[id] = self.edge_entities.len() as u32;
                self.edge_entities.push(e);
                self.edges.push([NO_SLOT; 2]);
                self.edge_faces.push([NO_SLOT; 2]);
            }
            Kind::Face => {
                self.slot_of[id] = self.face_entities.len() as u32;
                self.face_entities.push(e);
                self.faces.push([NO_SLOT; 3]);
                self.face_edges.push([NO_SLOT; 3]);
            }
        }
    }

    /// Removes `e` from its dense list as hecs does (the last entity takes
    /// its slot), moving the per-slot arrays alike.
    fn remove_slot(&mut self, kind: Kind, e: Entity) -> Result<(), UpdateError> {
        let list = match kind {
            Kind::Vertex => &mut self.vertex_entities,
            Kind::Edge => &mut self.edge_entities,
            Kind::Face => &mut self.face_entities,
        };
        let s = self
            .slot_of
            .get(e.id() as usize)
            .copied()
            .unwrap_or(NO_SLOT) as usize;
        if list.get(s) != Some(&e) {
            return Err(UpdateError::Unknown(e));
        }
        list.swap_remove(s);
        let moved = list.get(s).copied();
        self.slot_of[e.id() as usize] = NO_SLOT;
        if let Some(m) = moved {
            self.slot_of[m.id() as usize] = s as u32;
        }
        match kind {
            Kind::Vertex => {
                let stride = self.ring_stride;
                let last = self.ring_len.len() - 1;
                if s != last {
                    for a in [&mut self.ring, &mut self.ring_edges, &mut self.ring_faces] {
                        a.copy_within(last * stride..(last + 1) * stride, s * stride);
                    }
                }
                self.ring_len.swap_remove(s);
                let new_len = self.ring.len() - stride;
                self.ring.truncate(new_len);
                self.ring_edges.truncate(new_len);
                self.ring_faces.truncate(new_len);
            }
            Kind::Edge => {
                self.edges.swap_remove(s);
                self.edge_faces.swap_remove(s);
            }
            Kind::Face => {
                self.faces.swap_remove(s);
                self.face_edges.swap_remove(s);
            }
        }
        Ok(())
    }

    /// Whether `self` describes the same mesh, slot for slot, as `other`
    /// (what a full rebuild must reproduce; the entity → slot map is
    /// compared for the mesh's entities only, and rings by their entries).
    pub fn same_as(&self, other: &Topology) -> bool {
        let n = self.vertex_count();
        self.vertex_entities == other.vertex_entities
            && self.edge_entities == other.edge_entities
            && self.face_entities == other.face_entities
            && self.edges == other.edges
            && self.edge_faces == other.edge_faces
            && self.faces == other.faces
            && self.face_edges == other.face_edges
            && (0..n).all(|v| {
                self.neighbours(v) == other.neighbours(v)
                    && self.ring_edges_of(v) == other.ring_edges_of(v)
                    && self.ring_faces_of(v) == other.ring_faces_of(v)
            })
            && self
                .vertex_entities
                .iter()
                .chain(&self.edge_entities)
                .chain(&self.face_entities)
                .all(|e| self.slot(*e) == other.slot(*e))
    }
}
