//! What the preview's keys do: the sampler, the view, the exposure, the depth, the camera's
//! framing, and P's screenshot.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Result};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::KeyCode;

use super::camera::FlyCamera;
use super::{App, MAX_HALF_STOPS};
use crate::render::{self, LightSampler};
use crate::scene::Camera;

impl App<'_, '_> {
    /// P: the current film as preview-NNNN.exr (+ .png, .json) in the working folder.
    pub(super) fn screenshot(&mut self) -> Result<()> {
        // A number none of whose three files exists: the user's preview-0000.json and .png
        // beside no .exr were replaced (an audit, 2026-12-06).
        let n = (0..10_000)
            .find(|n| {
                ["exr", "png", "json"]
                    .iter()
                    .all(|e| !Path::new(&format!("preview-{n:04}.{e}")).exists())
            })
            .ok_or_else(|| anyhow!("preview-0000 … preview-9999 all exist; move them away"))?;
        let out = PathBuf::from(format!("preview-{n:04}.exr"));
        let device = self.ctx.describe();
        let (scene, exposure) = (self.scene, self.exposure());
        // The window's size, not the reduced film of a camera in motion (P while a key was
        // held saved a 50×40 image of a 100×80 window: an audit, 2026-12-07): the camera
        // counts as resting from here, and a film resized here restarts below.
        self.last_change = None;
        let session = self.session()?;
        if session.spp() == 0 {
            // P right after a camera move, before the next frame: the film was just reset, and
            // an empty film is a black image (it was written so, with `spp: 0`).
            session.run_passes(1)?;
        }
        let result = session.result()?;
        let settings = session.settings().clone();
        let paths = crate::film::OutputPaths::new(&out)?;
        let mut report = render::report_json(scene, &settings, &result, &device);
        // The camera flown to, not the scene's; the samples the window had, not its
        // session's open-ended budget (4294967295 spp: an audit, 2026-12-06).
        report["camera"] = render::camera_json(&session.camera());
        report["budget"] = serde_json::json!({"spp": result.spp, "preview": true});
        crate::film::write_outputs_exposed(
            &paths,
            result.width,
            result.height,
            &result.mean(),
            &report,
            exposure,
        )?;
        self.ui.message(&format!(
            "wrote {} (+ .png, .json): {} spp at {}×{}",
            out.display(),
            result.spp,
            result.width,
            result.height
        ));
        Ok(())
    }

    pub(super) fn key(&mut self, code: KeyCode, event_loop: &ActiveEventLoop) -> Result<()> {
        let samplers = [
            KeyCode::Digit1,
            KeyCode::Digit2,
            KeyCode::Digit3,
            KeyCode::Digit4,
            KeyCode::Digit5,
            KeyCode::Digit6,
        ];
        if let Some(i) = samplers.iter().position(|k| *k == code) {
            self.sampler = LightSampler::ALL[i];
            self.per_pass = None;
            self.move_factor = 2;
            return Ok(());
        }
        match code {
            KeyCode::Escape => event_loop.exit(),
            KeyCode::KeyR => {
                self.sessions.remove(&(self.sampler, self.depth));
            }
            KeyCode::KeyV => {
                self.display_mode = (self.display_mode + 1) % 4;
                self.heat = None;
            }
            KeyCode::Equal | KeyCode::NumpadAdd => {
                self.half_stops = (self.half_stops + 1).min(MAX_HALF_STOPS)
            }
            KeyCode::Minus | KeyCode::NumpadSubtract => {
                self.half_stops = (self.half_stops - 1).max(-MAX_HALF_STOPS)
            }
            KeyCode::KeyG => {
                self.move_factor = 2;
                self.depth = if self.depth > 1 {
                    1
                } else if self.req.max_depth > 1 {
                    self.req.max_depth
                } else {
                    8
                };
                self.per_pass = None;
            }
            KeyCode::KeyF => {
                let c = Camera::framing(self.bounds.0, self.bounds.1);
                self.camera = FlyCamera::from_camera(&c, self.camera.speed);
                self.changed_camera();
            }
            KeyCode::Home => {
                self.camera = FlyCamera::from_camera(&self.scene.camera, self.camera.speed);
                self.changed_camera();
                self.view = self.scene.camera;
            }
            // A failed save (a read-only folder) is said, and the preview goes on: it ended
            // the window, and what it had learned, with exit 1 (an audit, 2026-12-06).
            KeyCode::KeyP => {
                if let Err(e) = self.screenshot() {
                    self.ui.message(&format!(
                        "error: {e:#}; nothing was saved, the preview goes on"
                    ));
                }
            }
            _ => {}
        }
        Ok(())
    }
}
