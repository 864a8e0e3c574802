//! `lightlearn scene`: a procedural many-light scene written as glTF.

use std::path::Path;

use anyhow::{bail, Result};

use crate::scene::families::{self, Family, FamilyParams};

/// Writes the scene of `family` with `params` to `out` (.glb, or .gltf with embedded
/// buffers) atomically; returns its size in bytes. An existing `out` that this command did
/// not write is refused unless `force`: a user's own scene (even read-only) was replaced
/// without a word (an audit, 2026-12-07).
pub fn run(family: Family, params: &FamilyParams, out: &Path, force: bool) -> Result<usize> {
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
    if !force && out.is_file() && !written_by_us(out) {
        bail!(
            "'{}' exists and was not written by `lightlearn scene`; name another --out, or add --force to replace it",
            out.display()
        );
    }
    let builder = families::generate(family, params)?;
    let bytes = if text {
        builder.to_gltf_embedded().into_bytes()
    } else {
        builder.to_glb()
    };
    crate::io::write_atomic(out, &bytes)?;
    Ok(bytes.len())
}

/// Whether the glTF at `p` (.glb or .gltf) names lightlearn as its generator, as every scene
/// this command writes does. Only the JSON's `asset` is kept while reading (a .gltf of a
/// million lights is 300 MB, its buffers embedded).
fn written_by_us(p: &Path) -> bool {
    #[derive(serde::Deserialize)]
    struct Doc {
        asset: Asset,
    }
    #[derive(serde::Deserialize)]
    struct Asset {
        generator: Option<String>,
    }
    let Ok(file) = std::fs::File::open(p) else {
        return false;
    };
    let mut r = std::io::BufReader::new(file);
    let mut head = [0u8; 20];
    let doc: Option<Doc> =
        if std::io::Read::read_exact(&mut r, &mut head).is_ok() && &head[..4] == b"glTF" {
            // A GLB: the JSON chunk's length, then the chunk.
            let len = u32::from_le_bytes([head[12], head[13], head[14], head[15]]) as u64;
            let mut json = Vec::new();
            std::io::Read::read_to_end(&mut std::io::Read::take(r, len), &mut json)
                .ok()
                .and_then(|_| serde_json::from_slice(&json).ok())
        } else {
            // A .gltf: the whole text, from its start again.
            std::io::Seek::rewind(&mut r)
                .ok()
                .and_then(|_| serde_json::from_reader(r).ok())
        };
    doc.and_then(|d| d.asset.generator)
        .is_some_and(|g| g == "lightlearn")
}
