//! Acceleration structures for ray casting.

pub mod bvh;
pub mod gpu_trace;

pub use bvh::Bvh;
