//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::Path;
use std::sync::Arc;

use lightlearn::gpu::{Context, ContextOptions};
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::{gltf_load, Scene};

/// A Vulkan context with the validation layer on: any validation error fails the test.
pub fn ctx() -> Arc<Context> {
    Context::new(&ContextOptions {
        device: std::env::var("LIGHTLEARN_TEST_DEVICE").ok(),
        validation: true,
    })
    .expect("a Vulkan device (run ci/setup.sh to install lavapipe)")
}

/// Loads a builder's scene through the real glTF path (.glb bytes → loader).
pub fn load(b: &GltfBuilder, name: &str) -> Scene {
    gltf_load::load_bytes(&b.to_glb(), name, Path::new("."), &mut |w| {
        panic!("unexpected warning: {w}")
    })
    .expect("test scene loads")
}

pub fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_lightlearn")
}
