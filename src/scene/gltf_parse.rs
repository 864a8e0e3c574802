//! Parsing a glTF/GLB file's JSON, with the animation channels that target what lightlearn
//! does not animate taken out first. glTF 2.0 lets an extension define a channel's target:
//! `target.node` is optional and `target.path` any string (KHR_animation_pointer's channels
//! have no node and the path "pointer"). The gltf crate refuses a channel without a node and
//! panics on an unknown path, so such files were refused as "not a valid glTF 2.0 file" or
//! "malformed in a way the parser could not report" (an audit, 2026-12-07); they now render
//! without those channels, with one warning, as without any extension lightlearn does not
//! read.

use std::borrow::Cow;

use gltf::json::validation::Checked;
use serde_json::Value;

/// The target paths of glTF 2.0's core.
const PATHS: [&str; 4] = ["translation", "rotation", "scale", "weights"];

/// The parsed file and, where channels were taken out, the warning that says which.
pub fn parse(bytes: &[u8], name: &str) -> gltf::Result<(gltf::Gltf, Option<String>)> {
    // The file as it is first: one read of the JSON where nothing needs taking out.
    let parsed = gltf::Gltf::from_slice_without_validation(bytes);
    let foreign = match &parsed {
        Err(_) => true,
        Ok(g) => g.as_json().animations.iter().any(|a| {
            a.channels
                .iter()
                .any(|c| matches!(c.target.path, Checked::Invalid))
        }),
    };
    if foreign {
        if let Some((cleaned, warning)) = without_foreign_channels(bytes, name) {
            return Ok((
                gltf::Gltf::from_slice_without_validation(&cleaned)?,
                Some(warning),
            ));
        }
    }
    Ok((parsed?, None))
}

/// `bytes` without the channels that have no node or a path outside the core's, and the
/// warning; None where there are none (or the JSON does not parse: the crate's own error
/// then says why).
fn without_foreign_channels(bytes: &[u8], name: &str) -> Option<(Vec<u8>, String)> {
    let glb = if bytes.starts_with(b"glTF") {
        Some(gltf::binary::Glb::from_slice(bytes).ok()?)
    } else {
        None
    };
    let json: &[u8] = glb.as_ref().map_or(bytes, |g| &g.json);
    let mut root: Value = serde_json::from_slice(json).ok()?;
    let mut dropped = Vec::new();
    for (a, anim) in root
        .get_mut("animations")?
        .as_array_mut()?
        .iter_mut()
        .enumerate()
    {
        let Some(channels) = anim.get_mut("channels").and_then(Value::as_array_mut) else {
            continue;
        };
        let mut c = 0;
        channels.retain(|ch| {
            let target = &ch["target"];
            let path = target["path"].as_str();
            // A node of the wrong type or a path that is not a string is malformed, not an
            // extension's: kept, for the parser to name.
            let foreign = target.get("node").is_none() || path.is_some_and(|p| !PATHS.contains(&p));
            if foreign {
                dropped.push(format!(
                    "animation {a} channel {c} (path '{}')",
                    path.unwrap_or("")
                ));
            }
            c += 1;
            !foreign
        });
    }
    if dropped.is_empty() {
        return None;
    }
    let json = serde_json::to_vec(&root).ok()?;
    let bytes = match glb {
        Some(g) => gltf::binary::Glb {
            header: g.header,
            json: Cow::Owned(json),
            bin: g.bin,
        }
        .to_vec()
        .ok()?,
        None => json,
    };
    let n = dropped.len();
    let shown = dropped
        .iter()
        .take(3)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    let more = if n > 3 { ", …" } else { "" };
    let warning = format!(
        "'{name}': {n} animation channel{} target{} no node's translation, rotation, scale or weights ({shown}{more}: an extension's targets, such as KHR_animation_pointer's); ignored, the scene renders without them (messages below number the channels without them)",
        if n == 1 { "" } else { "s" },
        if n == 1 { "s" } else { "" }
    );
    Some((bytes, warning))
}
