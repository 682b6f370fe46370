//! [`Membrane`]: the hecs world holding one membrane (closed, or open with
//! boundary loops), its structure
//! epoch and the derived caches (topology, dense position mirror).

use crate::mesh::SurfaceMesh;
use crate::mesh::components::{ControlPoint, Edge, Face, Force, LipidDensity, Position};
use crate::mesh::topology::{Topology, TopologyError};
use crate::mesh::vertex_field::{FieldTransfer, ScalarComponent, ScalarField, TransferPolicy};
use glam::DVec3;
use hecs::{Entity, World};
// Keys are small integer pairs looked up, never iterated: the fast
// non-cryptographic hash.
use rustc_hash::FxHashMap as HashMap;
use std::sync::Arc;

/// The membrane: a hecs [`World`] (the source of truth) plus derived caches.
///
/// Anything that spawns or despawns mesh entities, or rewires [`Edge`] /
/// [`Face`] references, must call [`Membrane::mark_structure_changed`] so the
/// topology cache is rebuilt before the next hot loop.
pub struct Membrane {
    /// The entity world.
    pub world: World,
    epoch: u64,
    topology: Topology,
    has_lipid: bool,
    fields: Vec<Arc<dyn FieldTransfer>>,
    /// Whether every incremental topology update is checked against a full
    /// rebuild ([`Membrane::set_check_updates`]).
    check_updates: bool,
}

impl Membrane {
    /// Spawns vertex, edge and face entities for `mesh`. With `lipid_density`
    /// every vertex also gets [`LipidDensity`]`(1.0)`.
    ///
    /// The mesh must be a valid triangulation (see
    /// [`crate::mesh::check_mesh`]); this is not re-checked here. A boundary
    /// edge's missing right face is [`Entity::DANGLING`] (its slot in the
    /// topology is [`crate::mesh::topology::NO_SLOT`]).
    pub fn from_mesh(mesh: &SurfaceMesh, lipid_density: bool) -> Result<Self, TopologyError> {
        let mut world = World::new();
        let vertices: Vec<Entity> = mesh
            .positions
            .iter()
            .map(|&p| {
                if lipid_density {
                    world.spawn((Position(p), Force::default(), LipidDensity(1.0)))
                } else {
                    world.spawn((Position(p), Force::default()))
                }
            })
            .collect();
        // Reserve face and edge entities first so every component can be
        // spawned fully wired (no per-face world lookups).
        let faces: Vec<Entity> = world.reserve_entities(mesh.faces.len() as u32).collect();
        let mut half_edge_face: HashMap<(u32, u32), usize> =
            HashMap::with_capacity_and_hasher(mesh.faces.len() * 3, Default::default());
        for (fi, f) in mesh.faces.iter().enumerate() {
            for k in 0..3 {
                half_edge_face.insert((f[k], f[(k + 1) % 3]), fi);
            }
        }
        let mut edge_of: HashMap<(u32, u32), Entity> =
            HashMap::with_capacity_and_hasher(mesh.faces.len() * 3 / 2, Default::default());
        let mut edges = Vec::with_capacity(mesh.faces.len() * 3 / 2);
        for f in &mesh.faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                if edge_of.contains_key(&key) {
                    continue;
                }
                let left = half_edge_face[&(a, b)];
                let right = half_edge_face
                    .get(&(b, a))
                    .map_or(Entity::DANGLING, |&r| faces[r]);
                let e = world.reserve_entity();
                edges.push((
                    e,
                    Edge {
                        vertices: [vertices[a as usize], vertices[b as usize]],
                        faces: [faces[left], right],
                    },
                ));
                edge_of.insert(key, e);
            }
        }
        for (fi, f) in mesh.faces.iter().enumerate() {
            let edge = |k: usize| {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                edge_of[&(a.min(b), a.max(b))]
            };
            let face = Face {
                vertices: [
                    vertices[f[0] as usize],
                    vertices[f[1] as usize],
                    vertices[f[2] as usize],
                ],
                edges: [edge(0), edge(1), edge(2)],
            };
            world.spawn_at(faces[fi], (face,));
        }
        for (e, edge) in edges {
            world.spawn_at(e, (edge,));
        }
        let topology = Topology::build(&world, 0)?;
        let mut fields: Vec<Arc<dyn FieldTransfer>> = Vec::new();
        if lipid_density {
            fields.push(Arc::new(ScalarField::<LipidDensity>::new(
                "lipid_density",
                TransferPolicy::Conserve,
            )));
        }
        Ok(Self {
            world,
            epoch: 0,
            topology,
            has_lipid: lipid_density,
            fields,
            check_updates: cfg!(debug_assertions),
        })
    }

    /// Registers a per-vertex field: vertices created by remeshing get its
    /// component and its values follow its transfer policy. The component
    /// must already be on every vertex (see [`Membrane::add_vertex_field`]).
    pub fn register_field(&mut self, field: impl FieldTransfer) {
        self.fields.push(Arc::new(field));
    }

    /// Adds component `C` to every vertex with the value `initial(slot,
    /// position)` and registers its transfer policy. A structural change:
    /// the topology cache is rebuilt before the next use.
    pub fn add_vertex_field<C: ScalarComponent>(
        &mut self,
        name: &str,
        policy: TransferPolicy,
        initial: impl Fn(usize, DVec3) -> f64,
    ) -> Result<(), TopologyError> {
        self.topology()?;
        let t = &self.topology;
        let values: Vec<(Entity, C)> = t
            .vertex_entities
            .iter()
            .enumerate()
            .map(|(slot, &e)| {
                let p = self
                    .world
                    .get::<&Position>(e)
                    .map(|p| p.0)
                    .unwrap_or(DVec3::NAN);
                (e, C::from_value(initial(slot, p)))
            })
            .collect();
        for (e, c) in values {
            let _ = self.world.insert_one(e, c);
        }
        self.register_field(ScalarField::<C>::new(name, policy));
        self.mark_structure_changed();
        Ok(())
    }

    /// Reads the vertex field `C` into `out` by dense slot of the cached
    /// topology (0 at a vertex without it), in one pass over the world.
    pub fn gather_vertex_field<C: ScalarComponent>(&self, out: &mut Vec<f64>) {
        gather_field::<C>(&self.world, &self.topology, out);
    }

    /// Writes `values` (by dense slot of the cached topology) into the
    /// vertices' `C` components, in one pass over the world; vertices
    /// without the component are left without it.
    pub fn scatter_vertex_field<C: ScalarComponent>(&mut self, values: &[f64]) {
        let slot_of = &self.topology.slot_of;
        for (e, c) in self.world.query_mut::<(Entity, &mut C)>() {
            if let Some(&slot) = slot_of.get(e.id() as usize)
                && let Some(&v) = values.get(slot as usize)
            {
                *c = C::from_value(v);
            }
        }
    }

    /// The registered per-vertex fields, in registration order.
    pub fn fields(&self) -> &[Arc<dyn FieldTransfer>] {
        &self.fields
    }

    /// Whether vertices carry [`LipidDensity`].
    pub fn has_lipid(&self) -> bool {
        self.has_lipid
    }

    /// Structure epoch: bumped by every topology change.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// Records a structural change; the topology cache is rebuilt lazily.
    pub fn mark_structure_changed(&mut self) {
        self.epoch += 1;
    }

    /// The topology cache, rebuilt first if the structure changed.
    pub fn topology(&mut self) -> Result<&Topology, TopologyError> {
        if self.topology.epoch != self.epoch {
            self.topology = Topology::build(&self.world, self.epoch)?;
        }
        Ok(&self.topology)
    }

    /// Whether every incremental topology update after an edit is checked
    /// against a full rebuild (O(N) per edit; default on in debug builds,
    /// and so in tests). The `gather_state` system sets it each tick from
    /// the run's `CheckInvariants`, so a test that turns the invariant
    /// checks off for a long run turns this one off too, and
    /// `--check-invariants` turns it on in release.
    pub fn set_check_updates(&mut self, on: bool) {
        self.check_updates = on;
    }

    /// Brings the topology cache up to date after an edit that made
    /// `changes` (in order), in O(patch) when the cache was current before
    /// it, by a full rebuild otherwise (or when a ring block overflows).
    /// With [`Membrane::set_check_updates`] (debug builds) the result is
    /// checked against a full rebuild.
    pub(crate) fn update_topology(
        &mut self,
        changes: &[crate::mesh::topology_update::WorldChange],
    ) -> Result<&Topology, TopologyError> {
        let current = self.topology.epoch == self.epoch;
        self.epoch += 1;
        let updated = current
            && match self.topology.apply_edit(&self.world, changes, self.epoch) {
                Ok(()) => true,
                // A ring block outgrown is expected (rarely); anything else
                // is a bug in the update, which debug builds report.
                Err(crate::mesh::topology_update::UpdateError::RingOverflow(_)) => false,
                Err(e) => {
                    debug_assert!(false, "incremental topology update failed: {e}");
                    false
                }
            };
        if !updated {
            self.topology = Topology::build(&self.world, self.epoch)?;
        }
        if self.check_updates {
            let full = Topology::build(&self.world, self.epoch)?;
            assert!(
                self.topology.same_as(&full),
                "the incremental topology update differs from a full rebuild"
            );
        }
        Ok(&self.topology)
    }

    /// The topology cache as last built (may be stale if the structure
    /// changed without a call to [`Membrane::topology`]).
    pub fn cached_topology(&self) -> &Topology {
        debug_assert_eq!(self.topology.epoch, self.epoch, "stale topology cache");
        &self.topology
    }

    /// Copies vertex positions into `out`, indexed by dense slot.
    pub fn gather_positions(&self, out: &mut Vec<DVec3>) {
        let t = &self.topology;
        out.resize(t.vertex_count(), DVec3::ZERO);
        for (e, p) in self.world.query::<(Entity, &Position)>().iter() {
            out[t.slot_of[e.id() as usize] as usize] = p.0;
        }
    }

    /// Copies lipid densities into `out`, indexed by dense slot (empty if the
    /// membrane has no lipid density).
    pub fn gather_lipid(&self, out: &mut Vec<f64>) {
        let t = &self.topology;
        out.clear();
        if !self.has_lipid {
            return;
        }
        out.resize(t.vertex_count(), 0.0);
        for (e, rho) in self.world.query::<(Entity, &LipidDensity)>().iter() {
            out[t.slot_of[e.id() as usize] as usize] = rho.0;
        }
    }

    /// Writes dense positions and total forces back to the world's
    /// [`Position`] and [`Force`] components in one pass over the vertices
    /// (in parallel batches on a large mesh; each entity's components are
    /// written by one task, so the result does not depend on the threads).
    pub fn scatter_positions_and_forces(&mut self, positions: &[DVec3], forces: &[DVec3]) {
        use rayon::prelude::*;
        let slot_of = &self.topology.slot_of;
        let write = |e: Entity, p: &mut Position, f: &mut Force| {
            let slot = slot_of[e.id() as usize] as usize;
            p.0 = positions[slot];
            f.0 = forces[slot];
        };
        let query = self
            .world
            .query_mut::<(Entity, &mut Position, &mut Force)>();
        if crate::util::parallel::splits(positions.len()) {
            let batches: Vec<_> = query
                .into_iter_batched(crate::util::parallel::grain() as u32)
                .collect();
            batches.into_par_iter().for_each(|batch| {
                for (e, p, f) in batch {
                    write(e, p, f);
                }
            });
        } else {
            for (e, p, f) in query {
                write(e, p, f);
            }
        }
    }

    /// Writes dense lipid densities back to the world (no-op without lipid).
    pub fn scatter_lipid(&mut self, density: &[f64]) {
        if !self.has_lipid {
            return;
        }
        let t = &self.topology;
        for (e, rho) in self.world.query_mut::<(Entity, &mut LipidDensity)>() {
            rho.0 = density[t.slot_of[e.id() as usize] as usize];
        }
    }

    /// Spawns a fixed control point; its index is the number of control
    /// points spawned before it.
    pub fn add_control_point(&mut self, point: ControlPoint) -> Entity {
        let index = self.world.query::<&ControlPoint>().iter().count() as u32;
        self.world
            .spawn((point, crate::mesh::components::ControlPointIndex(index)))
    }

    /// All control points, in world order.
    pub fn control_points(&self) -> Vec<ControlPoint> {
        self.world
            .query::<&ControlPoint>()
            .iter()
            .copied()
            .collect()
    }

    /// The current mesh (positions and faces by dense slot).
    pub fn to_mesh(&mut self) -> Result<SurfaceMesh, TopologyError> {
        self.topology()?;
        let mut positions = Vec::new();
        self.gather_positions(&mut positions);
        Ok(SurfaceMesh {
            positions,
            faces: self.topology.faces.clone(),
        })
    }
}

/// Reads the vertex field `C` of `world` into `out` by dense slot of
/// `topology` (0 at a vertex without it), in one pass over the world.
pub fn gather_field<C: ScalarComponent>(world: &World, topology: &Topology, out: &mut Vec<f64>) {
    out.clear();
    out.resize(topology.vertex_count(), 0.0);
    for (e, c) in world.query::<(Entity, &C)>().iter() {
        if let Some(&slot) = topology.slot_of.get(e.id() as usize)
            && let Some(x) = out.get_mut(slot as usize)
        {
            *x = c.value();
        }
    }
}
