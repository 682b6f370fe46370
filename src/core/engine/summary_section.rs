//! Sections a plugin adds to a run's `summary.json`, as recorders add
//! columns to `series.csv`: a term or plugin that has something to report
//! about the final state (the adhered vesicle against the continuum, for
//! one) registers a [`SummarySection`], and the run writes what it measures
//! under the section's name, beside the summary's own fields.
//!
//! Sections are measured once, at the end of a run, from the final state:
//! after a blow-up only those that ask for it
//! ([`SummarySection::on_blow_up`]). A section whose `measure` returns
//! `None` is left out. [`ResourceSection`] writes a resource as it stands
//! (the flips' counts).

use crate::engine::error::BuildError;
use crate::engine::simulation::{SimBuilder, Simulation};
use std::collections::BTreeMap;

/// One section of `summary.json`.
pub trait SummarySection: Send + 'static {
    /// The section's key in `summary.json` (letters, digits and `_`; unique
    /// among the sections, and not one of the summary's own fields).
    fn name(&self) -> &str;
    /// The section at the final state of `sim`, or `None` to leave it out
    /// (nothing to report for this run).
    fn measure(&self, sim: &Simulation) -> Option<serde_json::Value>;
    /// Whether the section is also written for a run that blew up (its
    /// final state is the last good one; default: no, a comparison with a
    /// reference shape means nothing there, while counts still do).
    fn on_blow_up(&self) -> bool {
        false
    }
}

/// A section that writes resource `T` as it stands at the end of the run
/// (also after a blow-up), left out when the simulation has no `T`.
pub struct ResourceSection<T> {
    name: &'static str,
    resource: std::marker::PhantomData<fn() -> T>,
}

impl<T> ResourceSection<T> {
    /// The section `name` holding resource `T`.
    pub fn new(name: &'static str) -> Self {
        Self {
            name,
            resource: std::marker::PhantomData,
        }
    }
}

impl<T> SummarySection for ResourceSection<T>
where
    T: crate::engine::resources::Resource + serde::Serialize,
{
    fn name(&self) -> &str {
        self.name
    }

    fn measure(&self, sim: &Simulation) -> Option<serde_json::Value> {
        let value = sim.resources().get::<T>().ok()?;
        serde_json::to_value(&*value).ok()
    }

    fn on_blow_up(&self) -> bool {
        true
    }
}

/// The registered sections, in registration order (a resource).
#[derive(Default)]
pub struct SummarySections(Vec<Box<dyn SummarySection>>);

impl std::fmt::Debug for SummarySections {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(self.0.iter().map(|s| s.name()))
            .finish()
    }
}

impl SummarySections {
    /// The names of the registered sections.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.0.iter().map(|s| s.name())
    }
}

impl SimBuilder {
    /// Registers a section of `summary.json` ([`SummarySection`]). Refused
    /// when its name is not letters, digits and `_`, or is already taken
    /// by another section.
    pub fn add_summary_section(
        &mut self,
        section: impl SummarySection,
    ) -> Result<&mut Self, BuildError> {
        let name = section.name().to_string();
        let invalid = |reason: String| BuildError::Invalid {
            field: format!("summary section `{name}`"),
            reason,
        };
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(invalid("a name is letters, digits and `_`".into()));
        }
        if !self.resources().contains::<SummarySections>() {
            self.insert_resource(SummarySections::default());
        }
        let sections = self
            .resource_mut::<SummarySections>()
            .expect("inserted above");
        if sections.names().any(|n| n == name) {
            return Err(invalid("another section has this name".into()));
        }
        sections.0.push(Box::new(section));
        Ok(self)
    }
}

impl Simulation {
    /// Every registered section measured at the current state, by name
    /// (sections returning `None` left out; empty without sections); after
    /// a blow-up (`completed` false) only those asking for it.
    pub fn summary_sections(&self, completed: bool) -> BTreeMap<String, serde_json::Value> {
        let Ok(sections) = self.resources().get::<SummarySections>() else {
            return BTreeMap::new();
        };
        sections
            .0
            .iter()
            .filter(|s| completed || s.on_blow_up())
            .filter_map(|s| Some((s.name().to_string(), s.measure(self)?)))
            .collect()
    }

    /// The names of the registered sections (for a caller that checks them
    /// against its own fields before a run).
    pub fn summary_section_names(&self) -> Vec<String> {
        self.resources()
            .get::<SummarySections>()
            .map(|s| s.names().map(str::to_string).collect())
            .unwrap_or_default()
    }
}
