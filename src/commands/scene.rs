//! `lightlearn scene`: a procedural many-light scene written as glTF.

use std::path::Path;

use anyhow::{bail, Result};

use crate::scene::families::{self, Family, FamilyParams};

/// Writes the scene of `family` with `params` to `out` (.glb, or .gltf with embedded
/// buffers) atomically; returns its size in bytes.
pub fn run(family: Family, params: &FamilyParams, out: &Path) -> Result<usize> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_lowercase);
    let text = match ext.as_deref() {
        Some("glb") => false,
        Some("gltf") => true,
        _ => bail!("--out '{}' must end in .glb or .gltf", out.display()),
    };
    crate::io::check_writable(out)?;
    let builder = families::generate(family, params)?;
    let bytes = if text {
        builder.to_gltf_embedded().into_bytes()
    } else {
        builder.to_glb()
    };
    crate::io::write_atomic(out, &bytes)?;
    Ok(bytes.len())
}
