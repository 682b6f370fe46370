//! Updating the topology cache after one edit in O(patch) instead of
//! rebuilding it from the whole world.
//!
//! The edit layer ([`crate::mesh::edit`]) records every spawn, despawn and edge
//! refresh it makes, in order ([`WorldChange`]). Dense slots follow the
//! world's storage order: hecs appends a spawned entity to its archetype
//! and fills a despawned entity's place with the archetype's last entity
//! (swap-remove). [`Topology::apply_edit`] replays those moves on the slot
//! arrays, renaming the moved entity's slot wherever the cache names it
//! (its faces, edges and neighbours' rings, reached through its own
//! entries), and then recomputes from the world only what the edit
//! rewired: the added faces, the spawned and refreshed edges, and the ring
//! blocks of the corners of removed and added faces. The result is what
//! [`Topology::build`] would give for the edited world; tests and debug
//! builds check that after every edit.

use crate::mesh::components::{Edge, Face};
use crate::mesh::topology::{NO_SLOT, Topology, TopologyError};
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
    /// The edited world is not a valid triangulation.
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

/// Pushes `x` unless present (the sets here hold a patch's few items).
fn insert(set: &mut Vec<Entity>, x: Entity) {
    if !set.contains(&x) {
        set.push(x);
    }
}

/// Replaces every `from` in `slots` by `to`.
fn rename(slots: &mut [u32], from: u32, to: u32) {
    for s in slots.iter_mut().filter(|s| **s == from) {
        *s = to;
    }
}

/// What an edit rewired, read from the cache before the edit.
struct Rewired {
    /// The faces it adds, with their components.
    added_faces: Vec<(Entity, Face)>,
    /// The edges it spawns or refreshes.
    edge_dirty: Vec<Entity>,
    /// The faces around each corner of a removed or added face after the
    /// edit: `fan_faces[fans[i].1..fans[i].2]` for corner `fans[i].0`.
    fan_faces: Vec<Entity>,
    /// One entry per corner, in first-seen order.
    fans: Vec<(Entity, usize, usize)>,
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
        // 1. What the edit rewired, read from the unchanged cache.
        let rewired = self.rewired(world, changes)?;
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
        // 3. Recompute what the edit rewired.
        self.recompute_faces(&rewired.added_faces)?;
        self.recompute_edges(world, &rewired.edge_dirty)?;
        self.recompute_rings(&rewired.fan_faces, &rewired.fans)?;
        self.epoch = epoch;
        Ok(())
    }

    /// Step 1 of [`Topology::apply_edit`], on the cache before the edit: the
    /// faces the edit removes and adds, the edges it spawns or refreshes,
    /// and the corners of those faces (whose rings change) with their faces
    /// after the edit.
    fn rewired(&self, world: &World, changes: &[WorldChange]) -> Result<Rewired, UpdateError> {
        let mut removed_faces = Vec::with_capacity(changes.len());
        let mut added_faces: Vec<(Entity, Face)> = Vec::with_capacity(changes.len());
        let mut edge_dirty: Vec<Entity> = Vec::with_capacity(changes.len());
        let mut ring_dirty: Vec<Entity> = Vec::with_capacity(2 * changes.len());
        for &c in changes {
            match c {
                WorldChange::DespawnFace(f) => {
                    removed_faces.push(f);
                    let s = self.face_slot(f).ok_or(UpdateError::Unknown(f))? as usize;
                    for v in self.faces[s] {
                        insert(&mut ring_dirty, self.vertex_entities[v as usize]);
                    }
                }
                WorldChange::SpawnFace(f) => {
                    let face = world
                        .get::<&Face>(f)
                        .map(|c| *c)
                        .map_err(|_| UpdateError::Unknown(f))?;
                    for v in face.vertices {
                        insert(&mut ring_dirty, v);
                    }
                    added_faces.push((f, face));
                }
                WorldChange::SpawnEdge(e) | WorldChange::UpdateEdge(e) => {
                    insert(&mut edge_dirty, e)
                }
                _ => {}
            }
        }
        // The faces around each of those corners after the edit (entities):
        // its cached ring's faces, less the removed ones, plus the added
        // ones using it. A corner the edit removes gets none.
        let mut fan_faces: Vec<Entity> = Vec::with_capacity(8 * ring_dirty.len());
        let mut fans: Vec<(Entity, usize, usize)> = Vec::with_capacity(ring_dirty.len());
        for &v in &ring_dirty {
            let start = fan_faces.len();
            if let Some(s) = self.vertex_slot(v) {
                fan_faces.extend(
                    self.ring_faces_of(s as usize)
                        .iter()
                        .filter(|&&f| f != NO_SLOT)
                        .map(|&f| self.face_entities[f as usize])
                        .filter(|f| !removed_faces.contains(f)),
                );
            }
            for (f, face) in &added_faces {
                if face.vertices.contains(&v) {
                    fan_faces.push(*f);
                }
            }
            fans.push((v, start, fan_faces.len()));
        }
        Ok(Rewired {
            added_faces,
            edge_dirty,
            fan_faces,
            fans,
        })
    }

    /// The vertex slot of `v`, which the cache must know.
    #[inline]
    fn known_vertex_slot(&self, v: Entity) -> Result<u32, UpdateError> {
        self.vertex_slot(v).ok_or(UpdateError::Unknown(v))
    }

    /// Step 3 of [`Topology::apply_edit`] for the added faces: their
    /// corners' and edges' slots.
    fn recompute_faces(&mut self, added_faces: &[(Entity, Face)]) -> Result<(), UpdateError> {
        for &(f, face) in added_faces {
            let Some(s) = self.face_slot(f) else {
                continue;
            };
            let mut corners = [0u32; 3];
            let mut face_edges = [0u32; 3];
            for k in 0..3 {
                corners[k] = self.known_vertex_slot(face.vertices[k])?;
                let e = face.edges[k];
                face_edges[k] = self.edge_slot(e).ok_or(UpdateError::Unknown(e))?;
            }
            self.faces[s as usize] = corners;
            self.face_edges[s as usize] = face_edges;
        }
        Ok(())
    }

    /// Step 3 of [`Topology::apply_edit`] for the spawned and refreshed
    /// edges (`edge_dirty`): their vertices' and faces' slots, read from
    /// `world`.
    fn recompute_edges(&mut self, world: &World, edge_dirty: &[Entity]) -> Result<(), UpdateError> {
        for &e in edge_dirty {
            let Some(s) = self.edge_slot(e) else {
                continue;
            };
            let edge = world
                .get::<&Edge>(e)
                .map(|c| *c)
                .map_err(|_| UpdateError::Unknown(e))?;
            self.edges[s as usize] = [
                self.known_vertex_slot(edge.vertices[0])?,
                self.known_vertex_slot(edge.vertices[1])?,
            ];
            self.edge_faces[s as usize] = edge.faces.map(|f| self.face_slot(f).unwrap_or(NO_SLOT));
        }
        Ok(())
    }

    /// Step 3 of [`Topology::apply_edit`] for the rings of the corners of
    /// removed and added faces that stay: each corner's faces after the
    /// edit (`fan_faces`, ranges `fans`), as sorted slots.
    fn recompute_rings(
        &mut self,
        fan_faces: &[Entity],
        fans: &[(Entity, usize, usize)],
    ) -> Result<(), UpdateError> {
        let mut fan: Vec<u32> = Vec::new();
        for &(v, start, end) in fans {
            let Some(s) = self.vertex_slot(v) else {
                continue; // removed by the edit
            };
            fan.clear();
            for f in &fan_faces[start..end] {
                fan.push(self.slot(*f).ok_or(UpdateError::Unknown(*f))?);
            }
            fan.sort_unstable();
            if fan.len() > self.ring_stride {
                return Err(UpdateError::RingOverflow(s));
            }
            match self.write_ring(s as usize, &fan) {
                // An open fan needs one entry more than its faces.
                Err(_) if fan.len() == self.ring_stride => {
                    return Err(UpdateError::RingOverflow(s));
                }
                result => result?,
            }
        }
        Ok(())
    }

    /// Appends `e` to its dense list (a spawn), growing the per-slot arrays.
    /// Its entries are placeholders until step 3 of [`Topology::apply_edit`].
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
    /// its slot), moving the per-slot arrays alike and renaming the moved
    /// entity's old slot wherever the cache names it.
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
        let last = list.len() - 1;
        list.swap_remove(s);
        let moved = list.get(s).copied();
        self.slot_of[e.id() as usize] = NO_SLOT;
        if let Some(m) = moved {
            self.slot_of[m.id() as usize] = s as u32;
        }
        match kind {
            Kind::Vertex => {
                let stride = self.ring_stride;
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
        if s != last {
            self.rename_moved(kind, last as u32, s as u32);
        }
        Ok(())
    }

    /// After the entity at slot `from` moved to slot `to`: renames `from`
    /// to `to` wherever the cache names it, found through the moved
    /// entity's own entries. Entries that an edit rewires are recomputed
    /// in step 3 of [`Topology::apply_edit`]; this keeps every other entry
    /// right (an entry naming a slot no longer in use is skipped).
    fn rename_moved(&mut self, kind: Kind, from: u32, to: u32) {
        let stride = self.ring_stride;
        let t = to as usize;
        match kind {
            Kind::Vertex => {
                let block = t * stride..t * stride + self.ring_len[t] as usize;
                for k in block {
                    let (w, f, e) = (self.ring[k], self.ring_faces[k], self.ring_edges[k]);
                    if let Some(&len) = self.ring_len.get(w as usize) {
                        let lo = w as usize * stride;
                        rename(&mut self.ring[lo..lo + len as usize], from, to);
                    }
                    if let Some(face) = self.faces.get_mut(f as usize) {
                        rename(face, from, to);
                    }
                    if let Some(edge) = self.edges.get_mut(e as usize) {
                        rename(edge, from, to);
                    }
                }
            }
            Kind::Edge => {
                for f in self.edge_faces[t] {
                    if let Some(face_edges) = self.face_edges.get_mut(f as usize) {
                        rename(face_edges, from, to);
                    }
                }
                for v in self.edges[t] {
                    if let Some(&len) = self.ring_len.get(v as usize) {
                        let lo = v as usize * stride;
                        rename(&mut self.ring_edges[lo..lo + len as usize], from, to);
                    }
                }
            }
            Kind::Face => {
                for v in self.faces[t] {
                    if let Some(&len) = self.ring_len.get(v as usize) {
                        self.rename_ring_face(v as usize, len as usize, from, to);
                    }
                }
                for e in self.face_edges[t] {
                    if let Some(edge_faces) = self.edge_faces.get_mut(e as usize) {
                        rename(edge_faces, from, to);
                    }
                }
            }
        }
    }

    /// Renames face slot `from` to `to` in vertex `v`'s ring block of
    /// `len` entries and rotates the block to start at its least face slot,
    /// as [`Topology::write_ring`] orders it.
    fn rename_ring_face(&mut self, v: usize, len: usize, from: u32, to: u32) {
        let block = v * self.ring_stride..v * self.ring_stride + len;
        rename(&mut self.ring_faces[block.clone()], from, to);
        if self.ring_faces[block.clone()].last() == Some(&NO_SLOT) {
            return; // an open fan starts at its outgoing boundary edge
        }
        let first = self.ring_faces[block.clone()]
            .iter()
            .enumerate()
            .min_by_key(|&(_, &f)| f)
            .map_or(0, |(k, _)| k);
        if first != 0 {
            for a in [&mut self.ring, &mut self.ring_edges, &mut self.ring_faces] {
                a[block.clone()].rotate_left(first);
            }
        }
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
