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
//! - after the edit every affected edge has exactly one face on each side,
//!   every affected vertex has a single closed fan and a valence in range,
//!   and no new face is degenerate or folded over against the patch it
//!   replaces.
//!
//! A patch that would break any of these is rejected with an [`EditError`]
//! and the world is unchanged. A successful edit updates the topology
//! cache for its patch only ([`crate::mesh::topology_update`]).

use crate::mesh::ValenceRange;
use crate::mesh::components::{Edge, Face, Force, Position};
use crate::mesh::membrane::Membrane;
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

/// The faces of a patch before and after an edit.
struct PatchFans {
    /// The vertex triples of the faces to remove, in `remove_faces` order.
    removed_triples: Vec<[Entity; 3]>,
    /// Every vertex of a removed or added face, in first-seen order.
    affected: Vec<Entity>,
    /// Faces around the affected vertices after the edit:
    /// `after[fans[i].0..fans[i].1]` are `affected[i]`'s.
    after: Vec<[Entity; 3]>,
    /// Ranges into `after`, one per affected vertex.
    fans: Vec<(usize, usize)>,
}

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

    /// Checks `edit` against the current topology and geometry; the world is
    /// not changed. Returns the valence of every affected vertex after the
    /// edit.
    pub fn check_patch(
        &self,
        edit: &PatchEdit,
        valence: ValenceRange,
    ) -> Result<HashMap<Entity, usize>, EditError> {
        self.collect_valences(edit, valence, true)
    }

    /// [`Membrane::check_patch`] without the geometric checks (degenerate or
    /// folded faces): whether the edit is valid as a triangulation with
    /// valences in range, wherever the vertices are. Positions of added or
    /// moved vertices are ignored.
    pub fn check_patch_topology(
        &self,
        edit: &PatchEdit,
        valence: ValenceRange,
    ) -> Result<HashMap<Entity, usize>, EditError> {
        self.collect_valences(edit, valence, false)
    }

    /// The checks of [`Membrane::check_patch`] (with `geometry`) or
    /// [`Membrane::check_patch_topology`], without collecting the valences.
    pub(crate) fn validate_patch(
        &self,
        edit: &PatchEdit,
        valence: ValenceRange,
        geometry: bool,
    ) -> Result<(), EditError> {
        self.check_patch_with(edit, valence, geometry, |_, _| {})
    }

    fn collect_valences(
        &self,
        edit: &PatchEdit,
        valence: ValenceRange,
        geometry: bool,
    ) -> Result<HashMap<Entity, usize>, EditError> {
        let mut valences = HashMap::default();
        self.check_patch_with(edit, valence, geometry, |v, n| {
            valences.insert(v, n);
        })?;
        Ok(valences)
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
            |v, n| {
                valences.insert(v, n);
            },
        );
        Some(valences)
    }

    /// The vertex triples of `edit`'s faces to remove, in order; fails if
    /// one is not a live face.
    fn removed_triples(&self, edit: &PatchEdit) -> Result<Vec<[Entity; 3]>, EditError> {
        let t = self.cached_topology();
        edit.remove_faces
            .iter()
            .map(|&f| {
                let slot = t.face_slot(f).ok_or(EditError::UnknownFace(f))?;
                Ok(t.faces[slot as usize].map(|s| t.vertex_entities[s as usize]))
            })
            .collect()
    }

    /// The faces of `edit`'s patch: fails only if a face to remove is not
    /// live. A patch touches a few dozen entities, so these are small
    /// vectors searched linearly, not hash sets (the checks run for every
    /// candidate triangulation of every remesh event).
    fn patch_fans(&self, edit: &PatchEdit) -> Result<PatchFans, EditError> {
        let t = self.cached_topology();
        let removed = &edit.remove_faces;
        let removed_triples = self.removed_triples(edit)?;
        let affected = affected_vertices(&removed_triples, &edit.add_faces);
        let mut after: Vec<[Entity; 3]> = Vec::with_capacity(8 * affected.len());
        let mut fans: Vec<(usize, usize)> = Vec::with_capacity(affected.len());
        for &v in &affected {
            let start = after.len();
            if let Some(slot) = t.vertex_slot(v) {
                for &f in t.ring_faces_of(slot as usize) {
                    if !removed.contains(&t.face_entities[f as usize]) {
                        after.push(t.faces[f as usize].map(|s| t.vertex_entities[s as usize]));
                    }
                }
            }
            after.extend(edit.add_faces.iter().filter(|f| f.contains(&v)).copied());
            fans.push((start, after.len()));
        }
        Ok(PatchFans {
            removed_triples,
            affected,
            after,
            fans,
        })
    }

    /// Checks `edit` (the geometric checks only with `geometry`), calling
    /// `valence_of(v, valence)` for every affected vertex that stays.
    fn check_patch_with(
        &self,
        edit: &PatchEdit,
        valence: ValenceRange,
        geometry: bool,
        mut valence_of: impl FnMut(Entity, usize),
    ) -> Result<(), EditError> {
        let PatchFans {
            removed_triples,
            affected,
            after,
            fans,
        } = self.patch_fans(edit)?;
        if let Some(f) = edit
            .add_faces
            .iter()
            .find(|f| f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
        {
            return Err(EditError::DegenerateFace(*f));
        }
        // World positions of the affected vertices, looked up once.
        let world_position: Vec<Option<DVec3>> = affected
            .iter()
            .map(|&v| self.world.get::<&Position>(v).map(|p| p.0).ok())
            .collect();
        let world_at = |v: Entity| {
            affected
                .iter()
                .position(|&a| a == v)
                .and_then(|i| world_position[i])
        };
        // Geometry of the new faces: not degenerate, not folded over
        // against the area-weighted normal of the faces they replace.
        let position = |v: Entity| -> DVec3 {
            if let Some(&(_, p)) = edit.move_vertices.iter().find(|(e, _)| *e == v) {
                return p;
            }
            if let Some(&(_, p)) = edit.add_vertices.iter().find(|(e, _)| *e == v) {
                return p;
            }
            world_at(v).unwrap_or(DVec3::NAN)
        };
        let normal = |f: &[Entity; 3]| {
            let [a, b, c] = f.map(&position);
            ((b - a).cross(c - a), [a, b, c])
        };
        let patch_normal: DVec3 = removed_triples
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| world_at(v).unwrap_or(DVec3::ZERO));
                (b - a).cross(c - a)
            })
            .sum();
        for f in edit.add_faces.iter().filter(|_| geometry) {
            let (n, [a, b, c]) = normal(f);
            let longest = a
                .distance_squared(b)
                .max(b.distance_squared(c))
                .max(c.distance_squared(a));
            let shape = n.length() / longest;
            if shape.is_nan() || shape < MIN_FACE_SHAPE {
                return Err(EditError::DegenerateGeometry(*f));
            }
            if removed_triples
                .iter()
                .any(|t| t.iter().all(|v| f.contains(v)))
            {
                continue; // an unchanged face
            }
            if patch_normal.length_squared() > 0.0 && n.dot(patch_normal) <= 0.0 {
                return Err(EditError::FoldOver(*f));
            }
        }
        let removing = &edit.remove_vertices;
        let fan_of = |x: Entity| {
            let i = affected.iter().position(|&a| a == x).expect("affected");
            &after[fans[i].0..fans[i].1]
        };
        let mut link: Vec<(Entity, Entity)> = Vec::with_capacity(16);
        for &v in &affected {
            let faces = fan_of(v);
            if removing.contains(&v) {
                if !faces.is_empty() {
                    return Err(EditError::VertexStillUsed(v));
                }
                continue;
            }
            // Link of v: for face (v, a, b) the step a → b; one closed cycle.
            link.clear();
            for f in faces {
                let k = f.iter().position(|&x| x == v).expect("face contains v");
                let (from, to) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                if link.iter().any(|&(a, _)| a == from) {
                    return Err(EditError::BrokenFan(v));
                }
                link.push((from, to));
            }
            let Some(&(start, _)) = link.first() else {
                return Err(EditError::BrokenFan(v));
            };
            // The walk closes after |faces| steps from any start iff the
            // link is one cycle through every face.
            let mut cur = start;
            let mut steps = 0;
            loop {
                cur = link
                    .iter()
                    .find(|&&(a, _)| a == cur)
                    .map(|&(_, b)| b)
                    .ok_or(EditError::BrokenFan(v))?;
                steps += 1;
                if cur == start || steps > faces.len() {
                    break;
                }
            }
            if cur != start || steps != faces.len() {
                return Err(EditError::BrokenFan(v));
            }
            if steps < valence.min as usize || steps > valence.max as usize {
                return Err(EditError::Valence {
                    vertex: v,
                    valence: steps,
                });
            }
            valence_of(v, steps);
        }
        // Each affected edge: exactly one face per direction.
        for tri in removed_triples.iter().chain(&edit.add_faces) {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if removing.contains(&a) || removing.contains(&b) {
                    continue;
                }
                // Faces traversing x → y: in x's fan, y follows x.
                let count = |x: Entity, y: Entity| {
                    fan_of(x)
                        .iter()
                        .filter(|f| {
                            let k = f.iter().position(|&w| w == x).expect("face contains x");
                            f[(k + 1) % 3] == y
                        })
                        .count()
                };
                let (forward, backward) = (count(a, b), count(b, a));
                if forward + backward == 0 {
                    continue; // the edge disappears
                }
                if forward != 1 || backward != 1 {
                    return Err(EditError::EdgeFaces {
                        a,
                        b,
                        forward,
                        backward,
                    });
                }
            }
        }
        Ok(())
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
        let t = self.cached_topology();
        // Affected undirected edges and their current entities.
        let key = |a: Entity, b: Entity| {
            if a.to_bits() < b.to_bits() {
                (a, b)
            } else {
                (b, a)
            }
        };
        // Small maps of the patch, searched linearly (see `check_patch_with`).
        let mut edge_entity: Vec<((Entity, Entity), Entity)> = Vec::with_capacity(16);
        let set_edge = |map: &mut Vec<((Entity, Entity), Entity)>,
                        k: (Entity, Entity),
                        e: Entity| {
            match map.iter_mut().find(|(key, _)| *key == k) {
                Some(entry) => entry.1 = e,
                None => map.push((k, e)),
            }
        };
        let get_edge = |map: &[((Entity, Entity), Entity)], k: (Entity, Entity)| {
            map.iter().find(|(key, _)| *key == k).map(|&(_, e)| e)
        };
        // Room for a patch's edges: 17 to 21 for a split, as many for a merge.
        let mut keys: Vec<(Entity, Entity)> = Vec::with_capacity(32);
        let note = |a: Entity, b: Entity, keys: &mut Vec<(Entity, Entity)>| {
            let k = key(a, b);
            if !keys.contains(&k) {
                keys.push(k);
            }
        };
        for &f in &edit.remove_faces {
            let s = t.slot(f).expect("checked") as usize;
            let tri = t.faces[s].map(|v| t.vertex_entities[v as usize]);
            for m in 0..3 {
                let e = t.edge_entities[t.face_edges[s][m] as usize];
                set_edge(&mut edge_entity, key(tri[m], tri[(m + 1) % 3]), e);
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
            if get_edge(&edge_entity, (a, b)).is_some() {
                continue;
            }
            let slots = t.vertex_slot(a).zip(t.vertex_slot(b));
            if let Some(e) = slots.and_then(|(sa, sb)| t.edge_between(sa, sb)) {
                set_edge(&mut edge_entity, (a, b), t.edge_entities[e as usize]);
            }
        }
        // Faces after the edit, per affected edge key.
        let removed = &edit.remove_faces;
        let new_face_entities: Vec<Entity> = edit
            .add_faces
            .iter()
            .map(|_| self.world.reserve_entity())
            .collect();
        // faces_after[ranges[i].0..ranges[i].1]: the faces of edge keys[i]
        // after the edit.
        let mut faces_after: Vec<FaceRef> = Vec::with_capacity(2 * keys.len());
        let mut ranges: Vec<(usize, usize)> = Vec::with_capacity(keys.len());
        for &(a, b) in &keys {
            let start = faces_after.len();
            if let Some(slot) = t.vertex_slot(a) {
                for &f in t.ring_faces_of(slot as usize) {
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

        // Act, recording each change for the topology update.
        let mut changes =
            Vec::with_capacity(2 * (edit.remove_faces.len() + edit.add_faces.len()) + keys.len());
        for &f in &edit.remove_faces {
            if self.world.despawn(f).is_ok() {
                changes.push(WorldChange::DespawnFace(f));
            }
        }
        for &(v, p) in &edit.add_vertices {
            // Every registered per-vertex field's component, in one spawn
            // (values are set by the fields' transfer policies afterwards).
            let mut vertex = hecs::EntityBuilder::new();
            vertex.add(Position(p)).add(Force::default());
            for field in self.fields() {
                field.add_to(&mut vertex);
            }
            self.world.spawn_at(v, vertex.build());
            changes.push(WorldChange::SpawnVertex(v));
        }
        let mut outcome = EditOutcome {
            faces: new_face_entities.clone(),
            ..Default::default()
        };
        let mut final_edge: Vec<((Entity, Entity), Entity)> = Vec::with_capacity(keys.len());
        for (&(a, b), &(start, end)) in keys.iter().zip(&ranges) {
            let list = &faces_after[start..end];
            let existing = get_edge(&edge_entity, (a, b));
            if list.is_empty() {
                if let Some(e) = existing
                    && self.world.despawn(e).is_ok()
                {
                    changes.push(WorldChange::DespawnEdge(e));
                    outcome.edges_removed += 1;
                }
                continue;
            }
            let left = list
                .iter()
                .find(|(_, f)| (0..3).any(|m| f[m] == a && f[(m + 1) % 3] == b));
            let right = list
                .iter()
                .find(|(_, f)| (0..3).any(|m| f[m] == b && f[(m + 1) % 3] == a));
            let (Some(left), Some(right)) = (left, right) else {
                unreachable!("checked: one face per side");
            };
            let edge = Edge {
                vertices: [a, b],
                faces: [left.0, right.0],
            };
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
            set_edge(&mut final_edge, (a, b), e);
        }
        for (i, tri) in edit.add_faces.iter().enumerate() {
            let edges = [0, 1, 2].map(|m| {
                get_edge(&final_edge, key(tri[m], tri[(m + 1) % 3])).expect("an edge of a new face")
            });
            self.world.spawn_at(
                new_face_entities[i],
                (Face {
                    vertices: *tri,
                    edges,
                },),
            );
            changes.push(WorldChange::SpawnFace(new_face_entities[i]));
        }
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
        outcome
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

    /// Calls `visit(v, valence after the edit)` for every vertex of a face
    /// that an edit removing these counts' faces removes or adds
    /// (`add_faces`), once each in first-seen order (removed faces first),
    /// except the vertices it removes (`remove_vertices`). A vertex's faces
    /// after the edit are its valence (one face per neighbour in a closed
    /// fan): the faces it keeps plus the added faces that use it.
    pub fn for_each_valence(
        &self,
        m: &Membrane,
        add_faces: &[[Entity; 3]],
        remove_vertices: &[Entity],
        mut visit: impl FnMut(Entity, usize),
    ) {
        let added = |v: Entity| add_faces.iter().filter(|f| f.contains(&v)).count();
        for &(v, kept) in &self.kept {
            if !remove_vertices.contains(&v) {
                visit(v, kept + added(v));
            }
        }
        let t = m.cached_topology();
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
        .filter(|&&f| !remove_faces.contains(&t.face_entities[f as usize]))
        .count()
}

/// Every vertex of the removed and the added faces, once each, in
/// first-seen order (removed faces first).
fn affected_vertices(removed: &[[Entity; 3]], added: &[[Entity; 3]]) -> Vec<Entity> {
    let mut affected: Vec<Entity> = Vec::with_capacity(2 * removed.len() + 4);
    for &v in removed.iter().chain(added).flatten() {
        if !affected.contains(&v) {
            affected.push(v);
        }
    }
    affected
}
