//! The checks of a [`PatchEdit`] against the module contract of
//! [`crate::mesh::edit`]: new faces well formed and not folded over, every
//! affected vertex with one fan (closed inside, open on a boundary, as
//! before the edit) and a valence in range, every affected edge with one
//! face on each side (or one, on a boundary, as before the edit).
//!
//! A patch touches a few dozen entities, so its sets here are small vectors
//! searched linearly, not hash sets (the checks run for every candidate
//! triangulation of every remesh event).

use super::{EditError, MIN_FACE_SHAPE, PatchEdit};
use crate::mesh::ValenceRange;
use crate::mesh::components::Position;
use crate::mesh::membrane::Membrane;
use crate::mesh::topology::NO_SLOT;
use glam::DVec3;
use hecs::Entity;
use rustc_hash::FxHashMap as HashMap;

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
    /// Per affected vertex: whether it is on a boundary before the edit
    /// (`None`: a vertex the edit adds).
    open_before: Vec<Option<bool>>,
}

impl PatchFans {
    /// The faces around the affected vertex `x` after the edit.
    #[inline]
    fn fan_of(&self, x: Entity) -> &[[Entity; 3]] {
        let i = self
            .affected
            .iter()
            .position(|&a| a == x)
            .expect("affected");
        &self.after[self.fans[i].0..self.fans[i].1]
    }

    /// How many faces traverse the edge `x` → `y` after the edit: those of
    /// `x`'s fan in which `y` follows `x`.
    #[inline]
    fn faces_traversing(&self, x: Entity, y: Entity) -> usize {
        self.fan_of(x)
            .iter()
            .filter(|f| {
                let k = f.iter().position(|&w| w == x).expect("face contains x");
                f[(k + 1) % 3] == y
            })
            .count()
    }
}

impl Membrane {
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

    /// Checks `edit` (the geometric checks only with `geometry`) and
    /// returns the valence of every affected vertex that stays.
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
    /// live.
    fn patch_fans(&self, edit: &PatchEdit) -> Result<PatchFans, EditError> {
        let t = self.cached_topology();
        let removed = &edit.remove_faces;
        let removed_triples = self.removed_triples(edit)?;
        let affected = affected_vertices(&removed_triples, &edit.add_faces);
        let mut after: Vec<[Entity; 3]> = Vec::with_capacity(8 * affected.len());
        let mut fans: Vec<(usize, usize)> = Vec::with_capacity(affected.len());
        let mut open_before: Vec<Option<bool>> = Vec::with_capacity(affected.len());
        for &v in &affected {
            let start = after.len();
            let slot = t.vertex_slot(v);
            open_before.push(slot.map(|s| t.is_boundary_vertex(s as usize)));
            if let Some(slot) = slot {
                for &f in t.ring_faces_of(slot as usize) {
                    if f != NO_SLOT && !removed.contains(&t.face_entities[f as usize]) {
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
            open_before,
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
        let patch = self.patch_fans(edit)?;
        if let Some(f) = edit
            .add_faces
            .iter()
            .find(|f| f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
        {
            return Err(EditError::DegenerateFace(*f));
        }
        if geometry {
            self.check_new_face_geometry(edit, &patch)?;
        }
        let removing = &edit.remove_vertices;
        let mut link: Vec<(Entity, Entity)> = Vec::with_capacity(16);
        let mut open_after: Vec<(Entity, bool)> = Vec::with_capacity(patch.affected.len());
        for (&v, &open_before) in patch.affected.iter().zip(&patch.open_before) {
            let faces = patch.fan_of(v);
            if removing.contains(&v) {
                if !faces.is_empty() {
                    return Err(EditError::VertexStillUsed(v));
                }
                continue;
            }
            let (steps, open) = fan_valence(v, faces, &mut link)?;
            // A vertex stays inside or on the boundary: an edit neither
            // punches a hole nor closes one.
            if open_before.is_some_and(|before| before != open) {
                return Err(EditError::BrokenFan(v));
            }
            let range = if open {
                valence.for_boundary()
            } else {
                valence
            };
            if steps < range.min as usize || steps > range.max as usize {
                return Err(EditError::Valence {
                    vertex: v,
                    valence: steps,
                });
            }
            open_after.push((v, open));
            valence_of(v, steps);
        }
        self.check_edge_sides(edit, &patch, &open_after)
    }

    /// Geometry of `edit`'s new faces: not degenerate, not folded over
    /// against the area-weighted normal of the faces they replace.
    fn check_new_face_geometry(
        &self,
        edit: &PatchEdit,
        patch: &PatchFans,
    ) -> Result<(), EditError> {
        let affected = &patch.affected;
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
        let patch_normal: DVec3 = patch
            .removed_triples
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| world_at(v).unwrap_or(DVec3::ZERO));
                (b - a).cross(c - a)
            })
            .sum();
        for f in &edit.add_faces {
            let (n, corners) = normal(f);
            if !well_shaped(n, corners) {
                return Err(EditError::DegenerateGeometry(*f));
            }
            if patch
                .removed_triples
                .iter()
                .any(|t| t.iter().all(|v| f.contains(v)))
            {
                continue; // an unchanged face
            }
            if patch_normal.length_squared() > 0.0 && n.dot(patch_normal) <= 0.0 {
                return Err(EditError::FoldOver(*f));
            }
        }
        // On an open mesh a vertex that moves (a merge's survivor) keeps
        // faces outside the patch: they must not degenerate or turn over
        // (a rim is often straight, where the move can line them up). A
        // closed mesh's edits are left as they were (the paper's results
        // stay bit for bit).
        if edit.move_vertices.is_empty() || !self.cached_topology().is_open() {
            return Ok(());
        }
        for &(v, _) in &edit.move_vertices {
            if !affected.contains(&v) {
                continue;
            }
            for f in patch.fan_of(v) {
                if edit.add_faces.contains(f) {
                    continue;
                }
                let (n, corners) = normal(f);
                if !well_shaped(n, corners) {
                    return Err(EditError::DegenerateGeometry(*f));
                }
                let [a, b, c] = f.map(|x| world_at(x).unwrap_or(DVec3::ZERO));
                if n.dot((b - a).cross(c - a)) <= 0.0 {
                    return Err(EditError::FoldOver(*f));
                }
            }
        }
        Ok(())
    }
}

/// The valence (neighbour count) of `v` after the edit and whether its
/// fan is open, if its faces after the edit (`faces`) form one fan: a
/// closed one, or an open one between two boundary edges. Else
/// [`EditError::BrokenFan`]. `link` is scratch space for the fan's link.
fn fan_valence(
    v: Entity,
    faces: &[[Entity; 3]],
    link: &mut Vec<(Entity, Entity)>,
) -> Result<(usize, bool), EditError> {
    // Link of v: for face (v, a, b) the step a → b; one cycle or one path.
    link.clear();
    for f in faces {
        let k = f.iter().position(|&x| x == v).expect("face contains v");
        let (from, to) = (f[(k + 1) % 3], f[(k + 2) % 3]);
        if link.iter().any(|&(a, _)| a == from) {
            return Err(EditError::BrokenFan(v));
        }
        link.push((from, to));
    }
    let Some(&(first, _)) = link.first() else {
        return Err(EditError::BrokenFan(v));
    };
    // An open fan starts at the one neighbour that no step reaches.
    let open_start = link
        .iter()
        .map(|&(a, _)| a)
        .find(|&a| !link.iter().any(|&(_, b)| b == a));
    let start = open_start.unwrap_or(first);
    // The walk covers every face once iff the link is one cycle (closed)
    // or one path (open).
    let mut cur = start;
    let mut steps = 0;
    while let Some(next) = link.iter().find(|&&(a, _)| a == cur).map(|&(_, b)| b) {
        cur = next;
        steps += 1;
        if cur == start || steps > faces.len() {
            break;
        }
    }
    match open_start {
        None if cur == start && steps == faces.len() => Ok((steps, false)),
        Some(_) if cur != start && steps == faces.len() => Ok((steps + 1, true)),
        _ => Err(EditError::BrokenFan(v)),
    }
}

impl Membrane {
    /// Each edge of a removed or added face that stays (neither end
    /// removed) has one face per direction after the edit, or none (it
    /// disappears), or, on a boundary, one face: an edge that was on a
    /// boundary stays there, an interior one stays inside, and a new
    /// boundary edge joins two vertices whose fans are open after the edit
    /// (`open_after`).
    fn check_edge_sides(
        &self,
        edit: &PatchEdit,
        patch: &PatchFans,
        open_after: &[(Entity, bool)],
    ) -> Result<(), EditError> {
        let removing = &edit.remove_vertices;
        for tri in patch.removed_triples.iter().chain(&edit.add_faces) {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if removing.contains(&a) || removing.contains(&b) {
                    continue;
                }
                let (forward, backward) =
                    (patch.faces_traversing(a, b), patch.faces_traversing(b, a));
                if forward + backward == 0 {
                    continue; // the edge disappears
                }
                let error = EditError::EdgeFaces {
                    a,
                    b,
                    forward,
                    backward,
                };
                let open = |x: Entity| open_after.iter().any(|&(y, o)| y == x && o);
                if forward > 1 || backward > 1 {
                    return Err(error);
                }
                let both_open = open(a) && open(b);
                // Only an edge between boundary vertices can change sides.
                let was_boundary = both_open.then(|| self.boundary_edge_before(a, b));
                let inside = forward == 1 && backward == 1;
                let fine = match was_boundary {
                    None => inside,
                    Some(before) => before.is_none_or(|before| before != inside),
                };
                if !fine {
                    return Err(error);
                }
            }
        }
        Ok(())
    }

    /// Whether the edge `a`-`b` is on a boundary before the edit (`None`:
    /// there is no such edge).
    fn boundary_edge_before(&self, a: Entity, b: Entity) -> Option<bool> {
        let t = self.cached_topology();
        let (sa, sb) = (t.vertex_slot(a)?, t.vertex_slot(b)?);
        t.edge_between(sa, sb)
            .map(|e| t.is_boundary_edge(e as usize))
    }
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

/// Whether a face with (unnormalised) normal `n` and corners `[a, b, c]` is
/// far enough from degenerate: |n| over its longest edge squared at least
/// [`MIN_FACE_SHAPE`] (NaN fails).
fn well_shaped(n: DVec3, [a, b, c]: [DVec3; 3]) -> bool {
    let longest = a
        .distance_squared(b)
        .max(b.distance_squared(c))
        .max(c.distance_squared(a));
    let shape = n.length() / longest;
    !shape.is_nan() && shape >= MIN_FACE_SHAPE
}
