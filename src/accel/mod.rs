//! Acceleration structures for ray casting.

pub mod bvh;
pub mod gpu_trace;
mod traverse;

pub use bvh::Bvh;
