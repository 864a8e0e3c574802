//! The JSON report written beside every rendered image.

use super::{Budget, RenderResult, RenderSettings};
use crate::scene::{Camera, Scene};

/// The JSON report written beside every rendered image.
pub fn report_json(
    scene: &Scene,
    settings: &RenderSettings,
    result: &RenderResult,
    device: &str,
) -> serde_json::Value {
    // Null at 1 spp, where there is no variance.
    let (mse, rel) = result.known_error().unzip();
    let mut report = serde_json::json!({
        "lightlearn_version": env!("CARGO_PKG_VERSION"),
        "scene": scene.source,
        "scene_hash": crate::compare::reference::scene_hash(scene),
        // The random streams of the passes: `first_sample_index` .. + spp (a continuation of
        // loaded statistics starts after theirs). Parts to merge must not share them.
        "first_sample_index": result.first_sample_index,
        "triangles": scene.triangles.len(),
        "lights": scene.lights.len(),
        "sampler": settings.sampler.name(),
        "spp": result.spp,
        "width": settings.width,
        "height": settings.height,
        "seed": settings.seed,
        "budget": match settings.budget {
            Budget::Samples(n) => serde_json::json!({"spp": n}),
            Budget::Seconds(s) => serde_json::json!({"seconds": s}),
        },
        "render_seconds": result.render_seconds,
        "device": device,
        "invalid_samples_dropped": result.invalid_samples,
        "interrupted": result.interrupted,
        "learning": match &result.learned {
            Some(l) => serde_json::json!({
                "settings": settings.learn,
                "diagnostics": l.diagnostics,
                "samples_done_including_loaded": l.saved.header.samples_done,
            }),
            None => serde_json::Value::Null,
        },
        "regions": if settings.sampler.uses_cuts() {
            serde_json::json!({
                "grid": settings.regions.grid,
                "normal_bins": settings.regions.normal_bins,
                "tau": settings.regions.tau,
                "k_max": settings.regions.k_max,
                "in_cluster": if settings.regions.in_cluster_importance { "importance" } else { "power" },
                "coarse_blocks": settings.regions.coarse_blocks,
                "stats": result.regions,
            })
        } else {
            serde_json::Value::Null
        },
        "estimated_mse_of_mean": mse,
        "estimated_rel_mse_of_mean": rel,
        "zero_light_sample_fraction": result.zero_sample_fraction(),
        "integrator": if settings.max_depth == 1 {
            "direct illumination by light sampling, glTF metallic-roughness BRDF, one light sample per pixel sample".to_string()
        } else {
            format!("path tracing, up to {} surface vertices, glTF metallic-roughness BRDF (Lambert + GGX), next-event estimation + BSDF sampling with MIS (power heuristic), Russian roulette", settings.max_depth)
        },
        "max_depth": settings.max_depth,
        "light_point": settings.light_point,
        "indirect_light_samples": settings.indirect_light_samples,
        "first_light_samples": settings.first_light_samples,
        "stratify": settings.stratify.name(),
        "camera": camera_json(&scene.camera),
    });
    // Only where there are any, so other scenes' reports stay as they were.
    if !scene.directional.is_empty() {
        report["directional_lights"] = scene.directional.len().into();
    }
    report
}

/// The camera an image was rendered from, as its report gives it (the preview's screenshots
/// say where the user had flown to).
pub fn camera_json(camera: &Camera) -> serde_json::Value {
    serde_json::json!({
        "position": camera.position.to_array(),
        "forward": camera.forward.to_array(),
        "up": camera.up.to_array(),
        "yfov_degrees": camera.yfov.to_degrees(),
    })
}
