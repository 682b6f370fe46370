//! [`WorldSnapshot`]: the membrane's hecs world as data, restored entity for
//! entity so that a resumed run behaves bit for bit like the run that wrote
//! it.
//!
//! Results depend on more than the mesh: dense slots follow the world's
//! storage order (archetype by archetype, row by row), edges are keyed by
//! entity handles, and the entities that future splits and merges spawn come
//! from hecs' free list. A snapshot therefore keeps every entity's handle
//! (id and generation) in storage order and the free list, and
//! [`WorldSnapshot::restore`] spawns each entity at its handle in that order
//! and then sets the free list (`hecs::World::set_freelist`), which makes the
//! restored world hand out the same handles as the original.
//!
//! Only the membrane's own components can be saved: vertices ([`Position`],
//! [`Force`] and the registered per-vertex fields), edges, faces and control
//! points. An entity with any other component (a plugin's own entities) is
//! refused with an error naming it, never dropped silently.

use crate::mesh::components::{ControlPoint, ControlPointIndex, Edge, Face, Force, Position};
use crate::mesh::membrane::Membrane;
use hecs::{Entity, EntityBuilder, World};
use serde::{Deserialize, Serialize};
use std::any::TypeId;

/// One saved entity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum SavedEntity {
    /// A vertex: position (l̄), last total force (Ē/l̄) and the value of
    /// every registered per-vertex field, in registration order.
    Vertex {
        /// Entity handle bits.
        entity: u64,
        /// Position.
        position: [f64; 3],
        /// Last total force.
        force: [f64; 3],
        /// Field values, in the membrane's field order.
        fields: Vec<f64>,
    },
    /// An edge (handles of its vertices and faces).
    Edge {
        /// Entity handle bits.
        entity: u64,
        /// End vertices.
        vertices: [u64; 2],
        /// Left and right faces.
        faces: [u64; 2],
    },
    /// A face (handles of its corners and edges).
    Face {
        /// Entity handle bits.
        entity: u64,
        /// Corners.
        vertices: [u64; 3],
        /// Edges.
        edges: [u64; 3],
    },
    /// A control point.
    ControlPoint {
        /// Entity handle bits.
        entity: u64,
        /// Position (l̄).
        position: [f64; 3],
        /// Spring constant (Ē/l̄²).
        stiffness: f64,
        /// Declaration index.
        index: u32,
    },
}

/// The world of a [`Membrane`] as data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldSnapshot {
    /// Names of the per-vertex fields, in the order of the vertices' values.
    pub fields: Vec<String>,
    /// Every entity, in the world's storage order.
    pub entities: Vec<SavedEntity>,
    /// hecs' free list (handle bits), in its order.
    pub freelist: Vec<u64>,
}

/// Why a world could not be saved or restored.
#[derive(Debug, thiserror::Error)]
pub enum SnapshotError {
    /// An entity carries a component a snapshot cannot hold.
    #[error(
        "entity {entity:?} carries a component a checkpoint cannot save (only vertices, edges, faces, control points and registered per-vertex fields are saved)"
    )]
    Unsupported {
        /// The entity.
        entity: Entity,
    },
    /// The snapshot does not fit the membrane it is restored into.
    #[error("{0}")]
    Mismatch(String),
}

fn bits(e: Entity) -> u64 {
    e.to_bits().get()
}

fn entity(bits: u64) -> Result<Entity, SnapshotError> {
    Entity::from_bits(bits)
        .ok_or_else(|| SnapshotError::Mismatch(format!("{bits} is not an entity handle")))
}

impl WorldSnapshot {
    /// Saves `membrane`'s world.
    pub fn capture(membrane: &Membrane) -> Result<Self, SnapshotError> {
        let world = &membrane.world;
        let fields = membrane.fields();
        let vertex_types: Vec<TypeId> = [TypeId::of::<Position>(), TypeId::of::<Force>()]
            .into_iter()
            .chain(fields.iter().map(|f| f.component_type()))
            .collect();
        let exactly = |r: &hecs::EntityRef<'_>, types: &[TypeId]| {
            r.len() == types.len() && r.component_types().all(|t| types.contains(&t))
        };
        let control_types = [
            TypeId::of::<ControlPoint>(),
            TypeId::of::<ControlPointIndex>(),
        ];
        let mut entities = Vec::with_capacity(world.len() as usize);
        for r in world.iter() {
            let e = r.entity();
            let saved = if exactly(&r, &vertex_types) {
                let p = r.get::<&Position>().map(|p| p.0).unwrap_or_default();
                let f = r.get::<&Force>().map(|f| f.0).unwrap_or_default();
                SavedEntity::Vertex {
                    entity: bits(e),
                    position: p.to_array(),
                    force: f.to_array(),
                    fields: fields.iter().map(|field| field.get(world, e)).collect(),
                }
            } else if exactly(&r, &[TypeId::of::<Edge>()]) {
                let edge = *r.get::<&Edge>().expect("checked");
                SavedEntity::Edge {
                    entity: bits(e),
                    vertices: edge.vertices.map(bits),
                    faces: edge.faces.map(bits),
                }
            } else if exactly(&r, &[TypeId::of::<Face>()]) {
                let face = *r.get::<&Face>().expect("checked");
                SavedEntity::Face {
                    entity: bits(e),
                    vertices: face.vertices.map(bits),
                    edges: face.edges.map(bits),
                }
            } else if exactly(&r, &control_types) {
                let cp = *r.get::<&ControlPoint>().expect("checked");
                let index = r.get::<&ControlPointIndex>().expect("checked").0;
                SavedEntity::ControlPoint {
                    entity: bits(e),
                    position: cp.position.to_array(),
                    stiffness: cp.stiffness,
                    index,
                }
            } else {
                return Err(SnapshotError::Unsupported { entity: e });
            };
            entities.push(saved);
        }
        Ok(Self {
            fields: fields.iter().map(|f| f.name().to_string()).collect(),
            entities,
            freelist: world.freelist().map(bits).collect(),
        })
    }

    /// Replaces `membrane`'s world with the saved one. The membrane must
    /// have the same per-vertex fields (it is built from the same scene);
    /// its topology cache is rebuilt.
    pub fn restore(&self, membrane: &mut Membrane) -> Result<(), SnapshotError> {
        let names: Vec<&str> = membrane.fields().iter().map(|f| f.name()).collect();
        if names != self.fields {
            return Err(SnapshotError::Mismatch(format!(
                "the checkpoint's per-vertex fields are {:?}, the scene's are {names:?}",
                self.fields
            )));
        }
        let fields = membrane.fields().to_vec();
        // Every id below the largest is live or free, so a valid snapshot's
        // ids are below their total; this also bounds what a corrupt file
        // can make hecs allocate.
        let id_bound = (self.entities.len() + self.freelist.len()) as u64;
        let mut seen = std::collections::HashSet::with_capacity(self.entities.len());
        let mut world = World::new();
        for saved in &self.entities {
            let handle = match saved {
                SavedEntity::Vertex { entity: e, .. }
                | SavedEntity::Edge { entity: e, .. }
                | SavedEntity::Face { entity: e, .. }
                | SavedEntity::ControlPoint { entity: e, .. } => entity(*e)?,
            };
            if u64::from(handle.id()) >= id_bound || !seen.insert(handle.id()) {
                return Err(SnapshotError::Mismatch(format!(
                    "entity id {} is repeated or beyond the {id_bound} saved ids",
                    handle.id()
                )));
            }
            spawn_saved(&mut world, saved, &fields)?;
        }
        let freelist = self
            .freelist
            .iter()
            .map(|&b| entity(b))
            .collect::<Result<Vec<_>, _>>()?;
        let live: std::collections::HashSet<u32> = world.iter().map(|r| r.entity().id()).collect();
        let mut free_ids = std::collections::HashSet::with_capacity(freelist.len());
        if let Some(e) = freelist.iter().find(|e| {
            live.contains(&e.id()) || u64::from(e.id()) >= id_bound || !free_ids.insert(e.id())
        }) {
            return Err(SnapshotError::Mismatch(format!(
                "the free list names id {}, which is live, repeated or beyond the saved ids",
                e.id()
            )));
        }
        world.set_freelist(&freelist);
        membrane.world = world;
        membrane.mark_structure_changed();
        membrane
            .topology()
            .map_err(|e| SnapshotError::Mismatch(format!("the saved mesh is not valid: {e}")))?;
        Ok(())
    }
}

/// Spawns one saved entity into `world` at its saved id, with the scene's
/// per-vertex `fields` on a vertex.
fn spawn_saved(
    world: &mut World,
    saved: &SavedEntity,
    fields: &[std::sync::Arc<dyn crate::mesh::vertex_field::FieldTransfer>],
) -> Result<(), SnapshotError> {
    match saved {
        SavedEntity::Vertex {
            entity: e,
            position,
            force,
            fields: values,
        } => {
            if values.len() != fields.len() {
                return Err(SnapshotError::Mismatch(format!(
                    "vertex {e} has {} field values for {} fields",
                    values.len(),
                    fields.len()
                )));
            }
            let e = entity(*e)?;
            let mut b = EntityBuilder::new();
            b.add(Position(glam::DVec3::from_array(*position)))
                .add(Force(glam::DVec3::from_array(*force)));
            for field in fields {
                field.add_to(&mut b);
            }
            world.spawn_at(e, b.build());
            for (field, &v) in fields.iter().zip(values) {
                field.set(world, e, v);
            }
        }
        SavedEntity::Edge {
            entity: e,
            vertices,
            faces,
        } => {
            let edge = Edge {
                vertices: [entity(vertices[0])?, entity(vertices[1])?],
                faces: [entity(faces[0])?, entity(faces[1])?],
            };
            world.spawn_at(entity(*e)?, (edge,));
        }
        SavedEntity::Face {
            entity: e,
            vertices,
            edges,
        } => {
            let face = Face {
                vertices: [
                    entity(vertices[0])?,
                    entity(vertices[1])?,
                    entity(vertices[2])?,
                ],
                edges: [entity(edges[0])?, entity(edges[1])?, entity(edges[2])?],
            };
            world.spawn_at(entity(*e)?, (face,));
        }
        SavedEntity::ControlPoint {
            entity: e,
            position,
            stiffness,
            index,
        } => {
            let point = ControlPoint {
                position: glam::DVec3::from_array(*position),
                stiffness: *stiffness,
            };
            world.spawn_at(entity(*e)?, (point, ControlPointIndex(*index)));
        }
    }
    Ok(())
}
