//! Typed resources: the simulation state beside the hecs world's
//! components, one value per Rust type (the clock, the dense mirrors, the
//! force buffers, the V_in segmentation, remesh statistics, a plugin's own
//! state...).
//!
//! A system names what it reads and writes in its signature: its
//! [`crate::engine::schedule::System::Data`] is a tuple of [`Res`] (read),
//! [`ResMut`] (write) and `Option<...>` of them (present only if some
//! plugin inserted it). The schedule derives the system's [`Access`] from
//! that type, checks it when it is built, and hands the system exactly
//! those resources, so a typed system cannot reach one it did not declare.
//! Systems whose access is only known at run time (scripted terms) use a
//! [`crate::engine::schedule::DynamicSystem`], whose every access is checked
//! against its declaration.

use std::any::{Any, TypeId};
use std::cell::{Ref, RefCell, RefMut};
use std::collections::HashMap;
use std::ops::{Deref, DerefMut};

/// A value that can be stored as a resource: any `'static + Send` type.
pub trait Resource: Any + Send {}
impl<T: Any + Send> Resource for T {}

/// A resource type's identity and a readable name for messages.
///
/// Ids are made on every resource fetch, so making one costs no string work:
/// the name is shortened only when it is asked for. Two ids are equal when
/// their types are.
#[derive(Clone, Copy, Debug)]
pub struct ResourceId {
    type_id: TypeId,
    full_name: &'static str,
}

impl PartialEq for ResourceId {
    fn eq(&self, other: &Self) -> bool {
        self.type_id == other.type_id
    }
}

impl Eq for ResourceId {}

impl std::hash::Hash for ResourceId {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.type_id.hash(state);
    }
}

impl ResourceId {
    /// The id of resource type `T`.
    pub fn of<T: Resource>() -> Self {
        Self {
            type_id: TypeId::of::<T>(),
            full_name: std::any::type_name::<T>(),
        }
    }

    /// The type's name without its module path (e.g. `Clock`).
    pub fn name(&self) -> &'static str {
        short_type_name(self.full_name)
    }
}

impl std::fmt::Display for ResourceId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `a::b::C<d::E>` → `C<d::E>`: the last path segment before any generics.
fn short_type_name(full: &'static str) -> &'static str {
    let head = full.split('<').next().unwrap_or(full);
    match head.rfind("::") {
        Some(i) => &full[i + 2..],
        None => full,
    }
}

/// What a system reads and writes, by resource type.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Access {
    /// Resources read.
    pub reads: Vec<ResourceId>,
    /// Resources written (a write includes the read).
    pub writes: Vec<ResourceId>,
    /// Resources (read or written) the system can run without.
    pub optional: Vec<ResourceId>,
}

impl Access {
    /// Declares a read of `T`.
    pub fn read<T: Resource>(mut self) -> Self {
        self.reads.push(ResourceId::of::<T>());
        self
    }

    /// Declares a read of `T` that may be absent.
    pub fn read_optional<T: Resource>(mut self) -> Self {
        self.reads.push(ResourceId::of::<T>());
        self.optional.push(ResourceId::of::<T>());
        self
    }

    /// Adds every declaration of `other`.
    pub fn merge(&mut self, other: &Access) {
        for (mine, theirs) in [
            (&mut self.reads, &other.reads),
            (&mut self.writes, &other.writes),
            (&mut self.optional, &other.optional),
        ] {
            for id in theirs {
                if !mine.contains(id) {
                    mine.push(*id);
                }
            }
        }
    }

    /// Declares a write of `T`.
    pub fn write<T: Resource>(mut self) -> Self {
        self.writes.push(ResourceId::of::<T>());
        self
    }

    /// Whether `id` is read or written.
    pub fn touches(&self, id: ResourceId) -> bool {
        self.reads.contains(&id) || self.writes.contains(&id)
    }
}

/// A resource could not be handed to a system.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FetchError {
    /// No plugin inserted it.
    #[error("resource `{0}` does not exist (no plugin inserted it)")]
    Missing(ResourceId),
    /// It is already borrowed in a conflicting way (a system declared it
    /// twice, once for writing).
    #[error("resource `{0}` is already borrowed")]
    Borrowed(ResourceId),
    /// A dynamic system touched a resource it did not declare.
    #[error("resource `{resource}` is {} but was not declared {}", if *write { "written" } else { "read" }, if *write { "as a write" } else { "as a read or write" })]
    Undeclared {
        /// The resource.
        resource: ResourceId,
        /// Whether the access was a write.
        write: bool,
    },
}

struct Slot {
    id: ResourceId,
    value: RefCell<Box<dyn Any + Send>>,
}

/// Hashes a `TypeId` by its own bits: they are already a hash, and a
/// system fetches its resources on every tick.
#[derive(Default)]
struct TypeIdHasher(u64);

impl std::hash::Hasher for TypeIdHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 ^= v;
    }
}

type TypeMap<V> = HashMap<TypeId, V, std::hash::BuildHasherDefault<TypeIdHasher>>;

/// The resource container: at most one value per type.
#[derive(Default)]
pub struct Resources {
    slots: TypeMap<Slot>,
}

impl Resources {
    /// An empty container.
    pub fn new() -> Self {
        Self::default()
    }

    /// Inserts `value`, returning the value it replaces.
    pub fn insert<T: Resource>(&mut self, value: T) -> Option<T> {
        let id = ResourceId::of::<T>();
        let old = self.slots.insert(
            id.type_id,
            Slot {
                id,
                value: RefCell::new(Box::new(value)),
            },
        );
        old.and_then(|s| s.value.into_inner().downcast::<T>().ok().map(|b| *b))
    }

    /// Removes and returns the value of type `T`.
    pub fn remove<T: Resource>(&mut self) -> Option<T> {
        let slot = self.slots.remove(&TypeId::of::<T>())?;
        slot.value.into_inner().downcast::<T>().ok().map(|b| *b)
    }

    /// Whether a value of type `T` exists.
    pub fn contains<T: Resource>(&self) -> bool {
        self.slots.contains_key(&TypeId::of::<T>())
    }

    /// Whether a value with id `id` exists.
    pub fn contains_id(&self, id: ResourceId) -> bool {
        self.slots.contains_key(&id.type_id)
    }

    /// Ids of every resource, sorted by name.
    pub fn ids(&self) -> Vec<ResourceId> {
        let mut ids: Vec<ResourceId> = self.slots.values().map(|s| s.id).collect();
        ids.sort_by_key(|id| id.name());
        ids
    }

    /// Shared access to `T` (a runtime-checked borrow).
    pub fn get<T: Resource>(&self) -> Result<Res<'_, T>, FetchError> {
        let id = ResourceId::of::<T>();
        let slot = self.slots.get(&id.type_id).ok_or(FetchError::Missing(id))?;
        let cell = slot
            .value
            .try_borrow()
            .map_err(|_| FetchError::Borrowed(id))?;
        Ok(Res(Ref::map(cell, |b| {
            b.downcast_ref::<T>().expect("slot keyed by its type")
        })))
    }

    /// Exclusive access to `T` (a runtime-checked borrow).
    pub fn get_mut<T: Resource>(&self) -> Result<ResMut<'_, T>, FetchError> {
        let id = ResourceId::of::<T>();
        let slot = self.slots.get(&id.type_id).ok_or(FetchError::Missing(id))?;
        let cell = slot
            .value
            .try_borrow_mut()
            .map_err(|_| FetchError::Borrowed(id))?;
        Ok(ResMut(RefMut::map(cell, |b| {
            b.downcast_mut::<T>().expect("slot keyed by its type")
        })))
    }

    /// Direct mutable access when the container itself is held exclusively.
    pub fn value_mut<T: Resource>(&mut self) -> Option<&mut T> {
        self.slots
            .get_mut(&TypeId::of::<T>())
            .and_then(|s| s.value.get_mut().downcast_mut::<T>())
    }
}

/// Read access to resource `T` inside a system.
pub struct Res<'a, T: Resource>(Ref<'a, T>);

impl<T: Resource> Deref for Res<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

/// Write access to resource `T` inside a system.
pub struct ResMut<'a, T: Resource>(RefMut<'a, T>);

impl<T: Resource> Deref for ResMut<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<T: Resource> DerefMut for ResMut<'_, T> {
    fn deref_mut(&mut self) -> &mut T {
        &mut self.0
    }
}

/// The data a typed system receives: a resource handle or a tuple of them.
/// Its [`SystemData::declare`] is the system's declared access.
pub trait SystemData<'a>: Sized {
    /// Adds this data's reads and writes to `access`.
    fn declare(access: &mut Access);
    /// Borrows the data from `resources`.
    fn fetch(resources: &'a Resources) -> Result<Self, FetchError>;
}

impl<'a> SystemData<'a> for () {
    fn declare(_: &mut Access) {}
    fn fetch(_: &'a Resources) -> Result<Self, FetchError> {
        Ok(())
    }
}

impl<'a, T: Resource> SystemData<'a> for Res<'a, T> {
    fn declare(access: &mut Access) {
        access.reads.push(ResourceId::of::<T>());
    }
    fn fetch(resources: &'a Resources) -> Result<Self, FetchError> {
        resources.get::<T>()
    }
}

impl<'a, T: Resource> SystemData<'a> for ResMut<'a, T> {
    fn declare(access: &mut Access) {
        access.writes.push(ResourceId::of::<T>());
    }
    fn fetch(resources: &'a Resources) -> Result<Self, FetchError> {
        resources.get_mut::<T>()
    }
}

impl<'a, T: Resource> SystemData<'a> for Option<Res<'a, T>> {
    fn declare(access: &mut Access) {
        access.reads.push(ResourceId::of::<T>());
        access.optional.push(ResourceId::of::<T>());
    }
    fn fetch(resources: &'a Resources) -> Result<Self, FetchError> {
        match resources.get::<T>() {
            Ok(r) => Ok(Some(r)),
            Err(FetchError::Missing(_)) => Ok(None),
            Err(e) => Err(e),
        }
    }
}

impl<'a, T: Resource> SystemData<'a> for Option<ResMut<'a, T>> {
    fn declare(access: &mut Access) {
        access.writes.push(ResourceId::of::<T>());
        access.optional.push(ResourceId::of::<T>());
    }
    fn fetch(resources: &'a Resources) -> Result<Self, FetchError> {
        match resources.get_mut::<T>() {
            Ok(r) => Ok(Some(r)),
            Err(FetchError::Missing(_)) => Ok(None),
            Err(e) => Err(e),
        }
    }
}

macro_rules! tuple_data {
    ($($name:ident),+) => {
        impl<'a, $($name: SystemData<'a>),+> SystemData<'a> for ($($name,)+) {
            fn declare(access: &mut Access) {
                $($name::declare(access);)+
            }
            fn fetch(resources: &'a Resources) -> Result<Self, FetchError> {
                Ok(($($name::fetch(resources)?,)+))
            }
        }
    };
}

tuple_data!(A);
tuple_data!(A, B);
tuple_data!(A, B, C);
tuple_data!(A, B, C, D);
tuple_data!(A, B, C, D, E);
tuple_data!(A, B, C, D, E, F);
tuple_data!(A, B, C, D, E, F, G);
tuple_data!(A, B, C, D, E, F, G, H);
tuple_data!(A, B, C, D, E, F, G, H, I);
tuple_data!(A, B, C, D, E, F, G, H, I, J);
tuple_data!(A, B, C, D, E, F, G, H, I, J, K);
tuple_data!(A, B, C, D, E, F, G, H, I, J, K, L);

/// The resources a [`crate::engine::schedule::DynamicSystem`] may touch: every
/// borrow is checked against its declared [`Access`].
pub struct CheckedResources<'a> {
    resources: &'a Resources,
    access: &'a Access,
}

impl<'a> CheckedResources<'a> {
    /// A view of `resources` limited to `access`.
    pub fn new(resources: &'a Resources, access: &'a Access) -> Self {
        Self { resources, access }
    }

    /// Reads `T`; fails unless `T` was declared as a read or write.
    pub fn get<T: Resource>(&self) -> Result<Res<'a, T>, FetchError> {
        let id = ResourceId::of::<T>();
        if !self.access.touches(id) {
            return Err(FetchError::Undeclared {
                resource: id,
                write: false,
            });
        }
        self.resources.get::<T>()
    }

    /// Writes `T`; fails unless `T` was declared as a write.
    pub fn get_mut<T: Resource>(&self) -> Result<ResMut<'a, T>, FetchError> {
        let id = ResourceId::of::<T>();
        if !self.access.writes.contains(&id) {
            return Err(FetchError::Undeclared {
                resource: id,
                write: true,
            });
        }
        self.resources.get_mut::<T>()
    }
}
