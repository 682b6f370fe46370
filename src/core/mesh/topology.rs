//! The topology cache: dense index arrays derived from the hecs world.
//!
//! Built from the world once, then updated edit by edit in O(patch)
//! ([`Topology::apply_edit`], `src/mesh/topology_update.rs`); rebuilt in full only
//! when the structure changes outside the edit layer. Hot loops index these
//! arrays and never touch the world.
//!
//! Each vertex's ordered 1-ring lives in a fixed-size block of the ring
//! arrays (`ring_stride` entries, `valence` of them used), so an edit that
//! changes a valence rewrites that block alone.
//!
//! ## Open meshes
//!
//! A mesh may have boundary loops. A boundary edge has one face: it is
//! always the left one, `edge_faces[e] = [f, NO_SLOT]`, and `edges[e]` runs
//! the way `f` traverses it. A boundary vertex's ring is the ordered fan
//! from its outgoing boundary edge to its incoming one: `ring[0]` is the
//! next vertex along the boundary loop, `ring[valence − 1]` the previous
//! one, and the last ring face (which would close the fan) is `NO_SLOT`.
//! A vertex's valence is its number of neighbours in both cases. On a
//! closed mesh nothing here differs from before: every face slot is real.

use crate::mesh::components::{Edge, Face, Position};
use crate::util::parallel::{Incidence, entry};
use hecs::{Entity, World};
use std::sync::Arc;

/// Sentinel for "no slot".
pub const NO_SLOT: u32 = u32::MAX;

/// Dense mesh connectivity derived from the world.
#[derive(Clone, Debug, Default)]
pub struct Topology {
    /// Structure epoch this cache was built for.
    pub epoch: u64,
    /// Dense slot → vertex entity.
    pub vertex_entities: Vec<Entity>,
    /// Dense slot → edge entity.
    pub edge_entities: Vec<Entity>,
    /// Dense slot → face entity.
    pub face_entities: Vec<Entity>,
    /// `entity.id()` → dense slot within its kind (vertex, edge or face).
    pub slot_of: Vec<u32>,
    /// Edge end vertices (slots).
    pub edges: Vec<[u32; 2]>,
    /// Edge incident faces (slots): `[left, right]` as in [`Edge`]; a
    /// boundary edge's right face is [`NO_SLOT`].
    pub edge_faces: Vec<[u32; 2]>,
    /// Face corner vertices (slots), counter-clockwise from outside.
    pub faces: Vec<[u32; 3]>,
    /// Face edges (slots): `face_edges[f][k]` joins corners k and k+1.
    pub face_edges: Vec<[u32; 3]>,
    /// Entries per vertex block in the ring arrays (≥ every valence).
    pub(crate) ring_stride: usize,
    /// Valence of each vertex: the used length of its block.
    pub(crate) ring_len: Vec<u32>,
    /// Ordered 1-ring of each vertex, counter-clockwise about the outward
    /// normal (block `v`: entries `v·stride .. v·stride + valence`).
    pub(crate) ring: Vec<u32>,
    /// Entry `k` of a block: the edge to the ring's vertex `k`.
    pub(crate) ring_edges: Vec<u32>,
    /// Entry `k` of a block: the face (v, `ring[k]`, `ring[k+1]`); the last
    /// entry of a boundary vertex's block is [`NO_SLOT`].
    pub(crate) ring_faces: Vec<u32>,
    /// Each vertex's faces and edges in ascending slot order, built when
    /// first asked for ([`Topology::face_incidence`]).
    incidence: IncidenceCache,
}

/// The [`Topology::face_incidence`] and [`Topology::edge_incidence`] last
/// built, each with the topology it was built for ([`Topology::key`]).
#[derive(Default)]
struct IncidenceCache {
    faces: std::sync::Mutex<Option<(TopologyKey, Arc<Incidence>)>>,
    edges: std::sync::Mutex<Option<(TopologyKey, Arc<Incidence>)>>,
}

/// Identifies a state of one topology cache: its structure epoch (every
/// edit, full build or flip view sets a new one) and its counts.
pub type TopologyKey = (u64, usize, usize, usize);

impl Clone for IncidenceCache {
    fn clone(&self) -> Self {
        let copy = |m: &std::sync::Mutex<Option<(TopologyKey, Arc<Incidence>)>>| {
            std::sync::Mutex::new(m.lock().unwrap_or_else(|e| e.into_inner()).clone())
        };
        IncidenceCache {
            faces: copy(&self.faces),
            edges: copy(&self.edges),
        }
    }
}

impl std::fmt::Debug for IncidenceCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IncidenceCache")
    }
}

/// Ring block size for a largest valence `max_valence`: room for four
/// more neighbours than any vertex has, so valence changes by edits rarely
/// outgrow it (an edit that would falls back to a full rebuild).
fn ring_stride_for(max_valence: usize) -> usize {
    (max_valence + 4).max(10)
}

/// The world's mesh entities do not form a valid triangulation (closed, or
/// open with manifold boundary loops).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TopologyError {
    /// A face or edge refers to an entity that is not a vertex.
    #[error("{kind} entity {entity:?} refers to {target:?}, which is not a live vertex")]
    DanglingVertex {
        /// "face" or "edge".
        kind: &'static str,
        /// The referring entity.
        entity: Entity,
        /// The missing vertex.
        target: Entity,
    },
    /// A face refers to an entity that is not an edge.
    #[error("face entity {face:?} refers to {edge:?}, which is not a live edge")]
    DanglingEdge {
        /// The face.
        face: Entity,
        /// The missing edge.
        edge: Entity,
    },
    /// The faces around a vertex do not form one fan (closed, or open
    /// between two boundary edges).
    #[error("vertex slot {vertex} has a broken face fan (not manifold)")]
    BrokenFan {
        /// The vertex slot.
        vertex: u32,
    },
}

impl Topology {
    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertex_entities.len()
    }

    /// Valence (1-ring size) of vertex slot `v`.
    #[inline]
    pub fn valence(&self, v: usize) -> usize {
        self.ring_len[v] as usize
    }

    /// Where vertex `v`'s ring lives in the ring arrays.
    #[inline]
    fn ring_range(&self, v: usize) -> std::ops::Range<usize> {
        let lo = v * self.ring_stride;
        lo..lo + self.ring_len[v] as usize
    }

    /// Ordered 1-ring neighbours of vertex slot `v` (counter-clockwise about
    /// the outward normal).
    #[inline]
    pub fn neighbours(&self, v: usize) -> &[u32] {
        &self.ring[self.ring_range(v)]
    }

    /// The edges from vertex `v` to its [`Topology::neighbours`], in ring
    /// order.
    #[inline]
    pub fn ring_edges_of(&self, v: usize) -> &[u32] {
        &self.ring_edges[self.ring_range(v)]
    }

    /// The faces around vertex `v` in ring order: entry `k` is the face
    /// (v, `ring[k]`, `ring[k+1]`). A boundary vertex's last entry is
    /// [`NO_SLOT`] (see the module docs).
    #[inline]
    pub fn ring_faces_of(&self, v: usize) -> &[u32] {
        &self.ring_faces[self.ring_range(v)]
    }

    /// Whether vertex `v` lies on a boundary loop.
    #[inline]
    pub fn is_boundary_vertex(&self, v: usize) -> bool {
        self.ring_faces_of(v).last() == Some(&NO_SLOT)
    }

    /// Whether edge `e` has one face (lies on a boundary loop).
    #[inline]
    pub fn is_boundary_edge(&self, e: usize) -> bool {
        self.edge_faces[e][1] == NO_SLOT
    }

    /// Whether the mesh has a boundary (any edge with one face).
    pub fn is_open(&self) -> bool {
        self.edge_faces.iter().any(|f| f[1] == NO_SLOT)
    }

    /// Per vertex slot: whether it lies on a boundary loop.
    pub fn boundary_mask(&self) -> Vec<bool> {
        (0..self.vertex_count())
            .map(|v| self.is_boundary_vertex(v))
            .collect()
    }

    /// The boundary loops as vertex slots, each in the direction of its
    /// edges (the faces on its left seen from outside), starting at its
    /// lowest slot; loops in order of their first vertex. Empty for a
    /// closed mesh.
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        let mut seen = vec![false; self.vertex_count()];
        let mut loops = Vec::new();
        for v in 0..self.vertex_count() {
            if seen[v] || !self.is_boundary_vertex(v) {
                continue;
            }
            let mut l = Vec::new();
            let mut cur = v;
            while !seen[cur] {
                seen[cur] = true;
                l.push(cur as u32);
                cur = self.neighbours(cur)[0] as usize;
            }
            loops.push(l);
        }
        loops
    }

    /// The structure epoch and the vertex, edge and face counts: what a
    /// cache derived from this topology is valid for.
    pub fn key(&self) -> TopologyKey {
        (
            self.epoch,
            self.vertex_count(),
            self.edges.len(),
            self.faces.len(),
        )
    }

    /// Each vertex's faces in ascending slot order, with the vertex's
    /// corner in each ([`Incidence`]): the order in which a loop over the
    /// faces reaches the vertex, so a gather over it has that loop's bits.
    /// Built in parallel from the rings when first asked for at this
    /// topology ([`Topology::key`]) and kept until it changes.
    pub fn face_incidence(&self) -> Arc<Incidence> {
        self.cached(&self.incidence.faces, || {
            if self.ring_len.len() != self.vertex_count() {
                // No rings (a topology put together by hand).
                return Incidence::from_items(&self.faces, self.vertex_count());
            }
            Incidence::build(self.vertex_count(), self.ring_stride, |v, block| {
                let mut n = 0;
                for &f in self.ring_faces_of(v) {
                    if f != NO_SLOT {
                        block[n] = f;
                        n += 1;
                    }
                }
                let block = &mut block[..n];
                block.sort_unstable();
                for x in block.iter_mut() {
                    let f = *x as usize;
                    let k = self.faces[f].iter().position(|&c| c as usize == v);
                    *x = entry(f, k.expect("a ring face holds its vertex"));
                }
                n
            })
        })
    }

    /// Each vertex's edges in ascending slot order, with the vertex's end
    /// in each (0: `edges[e][0]`, 1: `edges[e][1]`); see
    /// [`Topology::face_incidence`].
    pub fn edge_incidence(&self) -> Arc<Incidence> {
        self.cached(&self.incidence.edges, || {
            if self.ring_len.len() != self.vertex_count() {
                return Incidence::from_items(&self.edges, self.vertex_count());
            }
            Incidence::build(self.vertex_count(), self.ring_stride, |v, block| {
                let ring = self.ring_edges_of(v);
                let block = &mut block[..ring.len()];
                block.copy_from_slice(ring);
                block.sort_unstable();
                for x in block.iter_mut() {
                    let e = *x as usize;
                    *x = entry(e, usize::from(self.edges[e][0] as usize != v));
                }
                ring.len()
            })
        })
    }

    /// The incidence in `slot` if it was built for this topology, else
    /// `build()` stored there. The lock is not held while building: a
    /// parallel build may run other tasks on this thread, which may ask.
    fn cached(
        &self,
        slot: &std::sync::Mutex<Option<(TopologyKey, Arc<Incidence>)>>,
        build: impl FnOnce() -> Incidence,
    ) -> Arc<Incidence> {
        let key = self.key();
        let lock = || slot.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((k, i)) = lock().as_ref()
            && *k == key
        {
            return i.clone();
        }
        let built = Arc::new(build());
        *lock() = Some((key, built.clone()));
        built
    }

    /// Dense slot of a mesh entity, if it is a live vertex, edge or face.
    pub fn slot(&self, entity: Entity) -> Option<u32> {
        let s = *self.slot_of.get(entity.id() as usize)?;
        (s != NO_SLOT).then_some(s)
    }

    /// Dense slot of a live vertex entity (generation checked).
    pub fn vertex_slot(&self, entity: Entity) -> Option<u32> {
        self.slot(entity)
            .filter(|&s| self.vertex_entities.get(s as usize) == Some(&entity))
    }

    /// Dense slot of a live edge entity (generation checked).
    pub fn edge_slot(&self, entity: Entity) -> Option<u32> {
        self.slot(entity)
            .filter(|&s| self.edge_entities.get(s as usize) == Some(&entity))
    }

    /// Dense slot of a live face entity (generation checked).
    pub fn face_slot(&self, entity: Entity) -> Option<u32> {
        self.slot(entity)
            .filter(|&s| self.face_entities.get(s as usize) == Some(&entity))
    }

    /// Slot of the edge joining vertex slots `a` and `b`, if any.
    pub fn edge_between(&self, a: u32, b: u32) -> Option<u32> {
        let a = a as usize;
        let k = self.neighbours(a).iter().position(|&w| w == b)?;
        Some(self.ring_edges_of(a)[k])
    }

    /// Builds the cache from the world's vertex ([`Position`]), [`Edge`] and
    /// [`Face`] entities. Slots follow the world's iteration order, which is
    /// deterministic for a given sequence of world edits.
    pub fn build(world: &World, epoch: u64) -> Result<Self, TopologyError> {
        let mut t = Topology {
            epoch,
            ..Default::default()
        };
        let max_id = world
            .iter()
            .map(|e| e.entity().id())
            .max()
            .map_or(0, |m| m as usize + 1);
        t.slot_of = vec![NO_SLOT; max_id];
        let mut is_vertex = vec![false; max_id];
        for (e, _) in world.query::<(Entity, &Position)>().iter() {
            t.slot_of[e.id() as usize] = t.vertex_entities.len() as u32;
            is_vertex[e.id() as usize] = true;
            t.vertex_entities.push(e);
        }
        let vertex_slot = |t: &Topology, kind, entity, target: Entity| {
            let id = target.id() as usize;
            if id < is_vertex.len()
                && is_vertex[id]
                && t.vertex_entities[t.slot_of[id] as usize] == target
            {
                Ok(t.slot_of[id])
            } else {
                Err(TopologyError::DanglingVertex {
                    kind,
                    entity,
                    target,
                })
            }
        };
        let mut edge_list = Vec::new();
        for (e, edge) in world.query::<(Entity, &Edge)>().iter() {
            edge_list.push((e, *edge));
        }
        for (slot, (e, edge)) in edge_list.iter().enumerate() {
            let a = vertex_slot(&t, "edge", *e, edge.vertices[0])?;
            let b = vertex_slot(&t, "edge", *e, edge.vertices[1])?;
            t.edges.push([a, b]);
            t.edge_entities.push(*e);
            t.slot_of[e.id() as usize] = slot as u32;
        }
        let mut face_list = Vec::new();
        for (e, face) in world.query::<(Entity, &Face)>().iter() {
            face_list.push((e, *face));
        }
        for (slot, (e, _)) in face_list.iter().enumerate() {
            t.slot_of[e.id() as usize] = slot as u32;
            t.face_entities.push(*e);
        }
        for (e, face) in &face_list {
            let mut corners = [0u32; 3];
            let mut edges = [0u32; 3];
            for k in 0..3 {
                corners[k] = vertex_slot(&t, "face", *e, face.vertices[k])?;
                let id = face.edges[k].id() as usize;
                let ok = id < t.slot_of.len()
                    && t.slot_of[id] != NO_SLOT
                    && (t.slot_of[id] as usize) < t.edge_entities.len()
                    && t.edge_entities[t.slot_of[id] as usize] == face.edges[k];
                if !ok {
                    return Err(TopologyError::DanglingEdge {
                        face: *e,
                        edge: face.edges[k],
                    });
                }
                edges[k] = t.slot_of[id];
            }
            t.faces.push(corners);
            t.face_edges.push(edges);
        }
        for (_, edge) in &edge_list {
            let f = edge
                .faces
                .map(|f| t.slot_of.get(f.id() as usize).copied().unwrap_or(NO_SLOT));
            t.edge_faces.push(f);
        }
        t.build_rings()?;
        Ok(t)
    }

    /// Builds every vertex's ordered 1-ring block from `faces` and
    /// `face_edges`.
    fn build_rings(&mut self) -> Result<(), TopologyError> {
        let n = self.vertex_entities.len();
        // Per vertex: its incident faces in ascending slot order (CSR).
        let mut count = vec![0u32; n + 1];
        for f in &self.faces {
            for &v in f {
                count[v as usize + 1] += 1;
            }
        }
        for v in 0..n {
            count[v + 1] += count[v];
        }
        let mut fill = count.clone();
        let mut incident = vec![0u32; self.faces.len() * 3];
        for (fi, f) in self.faces.iter().enumerate() {
            for &v in f {
                incident[fill[v as usize] as usize] = fi as u32;
                fill[v as usize] += 1;
            }
        }
        // A boundary vertex has one neighbour more than faces.
        let mut on_boundary = vec![0u32; n];
        for (e, f) in self.edge_faces.iter().enumerate() {
            if f[1] == NO_SLOT {
                for v in self.edges[e] {
                    on_boundary[v as usize] = 1;
                }
            }
        }
        let max_valence = (0..n)
            .map(|v| count[v + 1] - count[v] + on_boundary[v])
            .max()
            .unwrap_or(0);
        self.ring_stride = ring_stride_for(max_valence as usize);
        self.ring_len = vec![0; n];
        self.ring = vec![0; n * self.ring_stride];
        self.ring_edges = vec![0; n * self.ring_stride];
        self.ring_faces = vec![0; n * self.ring_stride];
        for v in 0..n {
            let fan = &incident[count[v] as usize..count[v + 1] as usize];
            self.write_ring(v, fan)?;
        }
        Ok(())
    }

    /// Writes vertex `v`'s ring block from its incident faces `fan` (face
    /// slots in ascending order; `faces` and `face_edges` must be current).
    /// An interior vertex's ring starts at the first face of `fan` and
    /// follows the faces counter-clockwise; a boundary vertex's starts at
    /// its outgoing boundary edge (see the module docs).
    pub(crate) fn write_ring(&mut self, v: usize, fan: &[u32]) -> Result<(), TopologyError> {
        let broken = TopologyError::BrokenFan { vertex: v as u32 };
        if fan.is_empty() || fan.len() > self.ring_stride {
            return Err(broken);
        }
        let corner_of = |f: u32| {
            let face = &self.faces[f as usize];
            (0..3).find(|&k| face[k] as usize == v)
        };
        // Face (v, a, b): the ring steps a → b.
        let next_of = |a: u32| {
            fan.iter().find_map(|&f| {
                let k = corner_of(f)?;
                (self.faces[f as usize][(k + 1) % 3] == a).then_some((f, k))
            })
        };
        // A fan that is open starts where no face steps onto its first
        // neighbour: (v, a, b) with no face (v, x, a).
        let steps_onto = |a: u32| {
            fan.iter()
                .any(|&f| corner_of(f).is_some_and(|k| self.faces[f as usize][(k + 2) % 3] == a))
        };
        let mut open_start = None;
        for &f in fan {
            let k = corner_of(f).ok_or(broken.clone())?;
            let a = self.faces[f as usize][(k + 1) % 3];
            if !steps_onto(a) {
                open_start = Some(a);
                break;
            }
        }
        let f0 = fan[0];
        let k0 = corner_of(f0).ok_or(broken.clone())?;
        let start = open_start.unwrap_or(self.faces[f0 as usize][(k0 + 1) % 3]);
        let len = fan.len() + usize::from(open_start.is_some());
        if len > self.ring_stride {
            return Err(broken);
        }
        let lo = v * self.ring_stride;
        let mut cur = start;
        for slot in lo..lo + fan.len() {
            let (fi, k) = next_of(cur).ok_or(broken.clone())?;
            let face = self.faces[fi as usize];
            self.ring[slot] = cur;
            self.ring_faces[slot] = fi;
            // Edge from v to cur is the face edge (k, k+1).
            self.ring_edges[slot] = self.face_edges[fi as usize][k];
            cur = face[(k + 2) % 3];
        }
        match open_start {
            None if cur != start => return Err(broken),
            None => {}
            Some(_) => {
                // The fan must end on a boundary edge: no face steps on from
                // the last neighbour (else the faces form more than one fan).
                if next_of(cur).is_some() {
                    return Err(broken);
                }
                let last = lo + fan.len();
                let (fi, k) = {
                    let f = self.ring_faces[last - 1];
                    (f, corner_of(f).ok_or(broken.clone())?)
                };
                self.ring[last] = cur;
                self.ring_faces[last] = NO_SLOT;
                // Edge from the last neighbour to v is the face edge (k+2, k).
                self.ring_edges[last] = self.face_edges[fi as usize][(k + 2) % 3];
            }
        }
        self.ring_len[v] = len as u32;
        Ok(())
    }
}
