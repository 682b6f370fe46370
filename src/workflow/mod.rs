//! Many runs: one run from a scene ([`run`]), protocols of phases,
//! parameter sweeps (local, or as Slurm scripts), their collection, two-scene
//! comparisons, the shape diagram, and the job pool they share.

pub mod collect;
pub mod compare;
pub mod job_pool;
pub mod protocol;
pub mod run;
pub mod shape_diagram;
pub mod slurm;
pub mod sweep;
