//! Per-vertex fields and how they are carried through remeshing (after
//! geometry-central's data transfer on mutation).
//!
//! A per-vertex field is a component on every vertex entity. The plugin
//! that owns it registers a [`FieldTransfer`] on the membrane
//! (`Membrane::register_field`); every split and merge then spawns new
//! vertices with the field's component and applies the field's
//! [`TransferPolicy`]:
//!
//! | policy | split (i1, i2) → (i1, n, i2) | merge (i1, i2) → i |
//! |---|---|---|
//! | [`TransferPolicy::Conserve`] (an amount, e.g. lipid) | f_i1, f_i2 ×= 2/3; f_n = (f_i1 + f_i2)/3 | f_i = f_i1 + f_i2 |
//! | [`TransferPolicy::Interpolate`] (an intensive value, e.g. coverage) | f_n = (f_i1 + f_i2)/2 | f_i = (f_i1 + f_i2)/2 |
//!
//! | [`TransferPolicy::Density`] (an amount whose density per area is the field, e.g. proteins) | every vertex of the edited patch keeps its density f/A; a new one gets its old neighbours' mean; the patch's Σf is kept | the same |
//!
//! Conserve keeps Σf exactly (lipid density: SPEC §5); Density keeps Σf and,
//! on any triangulation, the field f/A (also through flips, which the other
//! two leave alone).

use hecs::{Entity, EntityBuilder, World};
use std::marker::PhantomData;

/// How a field's values follow a split or merge (table in the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransferPolicy {
    /// The field is an amount: splits share it, merges add it; Σf is kept.
    Conserve,
    /// The field is intensive: new values are the mean of the edge's ends.
    Interpolate,
    /// The field is an amount whose density per vertex area is the smooth
    /// field (protein amounts): every edit, flips included, keeps the
    /// density of the vertices it touches and the sum of the amounts
    /// (`crate::mesh::edit`'s density transfer).
    Density,
}

/// A per-vertex scalar stored as a hecs component.
pub trait ScalarComponent: hecs::Component + Copy {
    /// The value.
    fn value(&self) -> f64;
    /// A component holding `value`.
    fn from_value(value: f64) -> Self;
}

impl ScalarComponent for crate::mesh::components::LipidDensity {
    fn value(&self) -> f64 {
        self.0
    }
    fn from_value(value: f64) -> Self {
        Self(value)
    }
}

/// One per-vertex field's transfer through topology edits.
pub trait FieldTransfer: Send + Sync + 'static {
    /// The field's name (for messages).
    fn name(&self) -> &str;
    /// Its policy.
    fn policy(&self) -> TransferPolicy;
    /// Adds the field's component (any value) to a vertex being spawned.
    fn add_to(&self, vertex: &mut EntityBuilder);
    /// The value at `vertex` (0 if it has none).
    fn get(&self, world: &World, vertex: Entity) -> f64;
    /// Sets the value at `vertex` (no-op if it has none).
    fn set(&self, world: &mut World, vertex: Entity, value: f64);
    /// The type of the field's component (checkpoints tell vertices by
    /// their component set).
    fn component_type(&self) -> std::any::TypeId;
}

/// The transfer of a [`ScalarComponent`] `C`.
pub struct ScalarField<C> {
    name: String,
    policy: TransferPolicy,
    component: PhantomData<fn() -> C>,
}

impl<C: ScalarComponent> ScalarField<C> {
    /// The field of component `C` named `name`, moved by `policy`.
    pub fn new(name: &str, policy: TransferPolicy) -> Self {
        Self {
            name: name.to_string(),
            policy,
            component: PhantomData,
        }
    }
}

impl<C: ScalarComponent> FieldTransfer for ScalarField<C> {
    fn name(&self) -> &str {
        &self.name
    }
    fn policy(&self) -> TransferPolicy {
        self.policy
    }
    fn add_to(&self, vertex: &mut EntityBuilder) {
        vertex.add(C::from_value(0.0));
    }
    fn get(&self, world: &World, vertex: Entity) -> f64 {
        world.get::<&C>(vertex).map(|c| c.value()).unwrap_or(0.0)
    }
    fn set(&self, world: &mut World, vertex: Entity, value: f64) {
        if let Ok(mut c) = world.get::<&mut C>(vertex) {
            *c = C::from_value(value);
        }
    }
    fn component_type(&self) -> std::any::TypeId {
        std::any::TypeId::of::<C>()
    }
}
