//! Vulkan through ash: context, buffers, compute pipelines, shader modules. Knows no
//! renderer; the host/shader structs are plain data in `crate::abi`.

pub mod buffer;
pub mod context;
/// The host/shader structs live in [`crate::abi`] (plain data, no device); this name stays
/// for the device code and the tests.
pub use crate::abi as layout;
pub mod pipeline;
pub mod spirv;
pub mod swapchain;
pub mod transfer;

pub use buffer::Buffer;
pub use context::{Context, ContextOptions};
pub use pipeline::ComputePipeline;
pub use transfer::Transfers;

/// Compiled kernels (build.rs runs glslangValidator on shaders/*.comp).
pub mod kernels {
    pub const RENDER: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/render.spv"));
    pub const TRACE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/trace.spv"));
    pub const LIGHT_SAMPLE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/light_sample.spv"));
    pub const FOLD: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/fold.spv"));
    pub const BSDF: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/bsdf.spv"));
    pub const IMPORTANCE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/importance.spv"));
    pub const PREVIEW: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/preview.spv"));
    pub const TEXELS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/texels.spv"));
}
