//! [`TermInputs`]: what systems of the Gather stage measure once per tick
//! for the force terms, by type, so that terms share a measurement instead
//! of each repeating it, and the force stage names none of them (V_in's
//! edge samples are one: [`crate::energy::vin::VinEdgeSamples`]).

use std::any::{Any, TypeId};

/// Values published for the force terms, one per type. A resource: the
/// plugin that measures a value inserts it at build time
/// ([`TermInputs::insert`]) and its Gather-stage system (with
/// `ResMut<TermInputs>`) refreshes it every tick; the `force_terms` system
/// hands it to every term ([`crate::engine::force::ForceContext::inputs`]),
/// which reads it with [`TermInputs::get`]. A value missing means it was not
/// measured: a term then measures what it needs itself.
#[derive(Default)]
pub struct TermInputs {
    values: Vec<(TypeId, Box<dyn Any + Send + Sync>)>,
}

/// No inputs: the context of an evaluation outside the schedule (finite
/// differences, flip proposals).
static NONE: TermInputs = TermInputs { values: Vec::new() };

impl TermInputs {
    /// No inputs, for a context outside the schedule.
    pub fn none() -> &'static TermInputs {
        &NONE
    }

    /// Inserts (or replaces) the value of type `T`.
    pub fn insert<T: Any + Send + Sync>(&mut self, value: T) {
        let id = TypeId::of::<T>();
        match self.values.iter_mut().find(|(t, _)| *t == id) {
            Some(slot) => slot.1 = Box::new(value),
            None => self.values.push((id, Box::new(value))),
        }
    }

    /// The value of type `T`, if published.
    pub fn get<T: Any + Send + Sync>(&self) -> Option<&T> {
        let id = TypeId::of::<T>();
        self.values
            .iter()
            .find(|(t, _)| *t == id)
            .and_then(|(_, v)| v.downcast_ref())
    }

    /// The value of type `T`, mutably (to refresh it), if published.
    pub fn get_mut<T: Any + Send + Sync>(&mut self) -> Option<&mut T> {
        let id = TypeId::of::<T>();
        self.values
            .iter_mut()
            .find(|(t, _)| *t == id)
            .and_then(|(_, v)| v.downcast_mut())
    }
}

impl crate::engine::simulation::SimBuilder {
    /// Publishes `value` for the force terms: inserts it into the
    /// [`TermInputs`] resource (which it inserts first if no plugin did).
    /// The publishing plugin's Gather-stage system refreshes it every tick.
    pub fn publish_term_input<T: Any + Send + Sync>(&mut self, value: T) -> &mut Self {
        match self.resource_mut::<TermInputs>() {
            Some(inputs) => inputs.insert(value),
            None => {
                let mut inputs = TermInputs::default();
                inputs.insert(value);
                self.insert_resource(inputs);
            }
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_found_by_type_and_replaced() {
        let mut inputs = TermInputs::default();
        assert!(inputs.get::<u32>().is_none());
        inputs.insert(3u32);
        inputs.insert(vec![1.0f64]);
        inputs.insert(4u32);
        assert_eq!(inputs.get::<u32>(), Some(&4));
        inputs.get_mut::<Vec<f64>>().unwrap().push(2.0);
        assert_eq!(inputs.get::<Vec<f64>>(), Some(&vec![1.0, 2.0]));
        assert!(TermInputs::none().get::<u32>().is_none());
    }
}
