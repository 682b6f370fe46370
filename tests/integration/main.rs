//! The integration tests, one binary: each module is one file of tests
//! (they were one binary each; one crate builds and links once, and the
//! test harness runs every module's tests side by side on every core).
//! `cargo test --test integration <module>::` runs one file's tests, e.g.
//! `cargo test --release --test integration fuzz:: -- --ignored`.

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
mod spectrum;
mod study;
mod sweep;
mod tether;
mod thermal;
mod threads;
mod tube_radius;
mod walls;
