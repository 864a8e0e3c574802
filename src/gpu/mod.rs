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
    /// render.comp for light sampler `sampler` (its SAMPLER, 0–5) and `direct_only` (its
    /// DIRECT_ONLY), the code of the others stripped (build.rs says why).
    pub fn render(sampler: u32, direct_only: bool) -> &'static [u8] {
        RENDER[sampler as usize][direct_only as usize]
    }

    /// Every variant of [`render`], for the tests that check them all.
    pub fn render_variants() -> impl Iterator<Item = &'static [u8]> {
        RENDER.iter().flatten().copied()
    }

    /// A sampler's two kernels (build.rs `render_s{S}_d{0,1}.spv`).
    macro_rules! render_pair {
        ($s:literal) => {
            [
                include_bytes!(concat!(env!("OUT_DIR"), "/render_s", $s, "_d0.spv")),
                include_bytes!(concat!(env!("OUT_DIR"), "/render_s", $s, "_d1.spv")),
            ]
        };
    }

    const RENDER: [[&[u8]; 2]; 6] = [
        render_pair!("0"),
        render_pair!("1"),
        render_pair!("2"),
        render_pair!("3"),
        render_pair!("4"),
        render_pair!("5"),
    ];
    pub const TRACE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/trace.spv"));
    pub const LIGHT_SAMPLE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/light_sample.spv"));
    pub const FOLD: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/fold.spv"));
    pub const BSDF: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/bsdf.spv"));
    pub const IMPORTANCE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/importance.spv"));
    pub const PREVIEW: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/preview.spv"));
    pub const TEXELS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/texels.spv"));
}
