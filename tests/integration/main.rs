//! The integration tests, one binary: each module is one file of tests
//! (they were one binary each; one crate builds and links once, and the
//! test harness runs every module's tests side by side on every core).
//! `cargo test --test integration <module>::` runs one file's tests.
//!
//! Tiers (docs/development.md): a test that takes more than about 2 s in
//! the test profile is `#[ignore = "slow tier: ..."]`; `.ci/run` runs the
//! ignored tests with `-- --ignored --skip by_hand_`. Runs too long for CI
//! (the long fuzzing and remeshing modes, minutes in release) are named
//! `by_hand_*`, e.g. `cargo test --release --test integration
//! fuzz::by_hand_ -- --ignored --nocapture`.

mod common;

mod adhesion;
mod checkpoint;
mod cli;
mod closed_forms;
mod control_points;
mod diffusion;
mod docs;
mod dynamics;
mod edge_flips;
mod fluid_model;
mod force_fd;
mod fuzz;
mod hard_cases;
mod mesh_invariants;
mod minimiser;
mod open_bending;
mod open_fd;
mod open_fluid;
mod open_mesh;
mod open_mesh_scenes;
mod open_remesh_scenes;
mod open_tether;
mod plugins;
mod protocol;
mod remesh_open;
mod remesh_ops;
mod remeshing;
mod run_dir;
mod scene_errors;
mod self_avoidance;
mod shape_and_render;
mod shape_diagram;
mod species;
mod species_transport;
mod spectrum;
mod study;
mod sweep;
mod tether;
mod thermal;
mod threads;
mod tube_radius;
mod walls;
