//! Benchmarks: commands that measure, never tests (timings vary on shared machines).

pub mod rays;
pub mod stages;
