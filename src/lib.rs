//! lightlearn: a GPU many-light renderer (Vulkan compute) built around Bayesian online
//! learning of light selection. See README.md and docs/ (docs/method.md for the method).

pub mod abi;
pub mod accel;
pub mod bench;
pub mod commands;
pub mod compare;
pub mod film;
pub mod fnv;
pub mod gpu;
pub mod interrupt;
pub mod io;
pub mod layer_albedo;
pub mod learning;
pub mod lights;
pub mod preview;
pub mod reference;
pub mod render;
pub mod rng;
pub mod scene;
pub mod variance;

/// The committed default scene, built into the binary so `lightlearn render` works from any
/// folder (source: scenes/default.glb, see scenes/README.md).
pub const DEFAULT_SCENE: &[u8] = include_bytes!("../scenes/default.glb");
pub const DEFAULT_SCENE_NAME: &str = "scenes/default.glb";
