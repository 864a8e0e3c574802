//! `lightlearn preview`: a window that shows a render session's film as it converges, with
//! a fly/orbit camera. A camera change resets the film and keeps what was learned (regions
//! live in world space); each sampler and depth has its own session, so switching keeps every
//! learned state. While the camera moves the film is rendered at reduced size and shown
//! upscaled; at rest it goes back to the window's size (as Cycles' viewport does).
//!
//! Keys: W/A/S/D/Q/E move, arrows or right-drag look, left-drag orbits,
//! wheel changes the speed (left-drag orbits the point under the cursor), F frames the scene, Home returns to its camera; 1–6 pick the
//! sampler (uniform, power, lightbvh, wang, donikian, bayes), R resets the learning, V
//! cycles image / relative error / zero-light-sample share / regions learned, +/- exposure, G direct light / path tracing, P saves
//! preview-NNNN.exr (+ .png, .json), Esc quits.

pub mod camera;
mod display;
mod heat;
mod keys;
mod window_system;

use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use glam::Vec3;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::accel::Bvh;
use crate::commands::Ui;
use crate::gpu::swapchain::Presented;
use crate::gpu::{Context, ContextOptions};
use crate::learning::LearnSettings;
use crate::lights::regions::RegionSettings;
use crate::render::{self, Budget, GpuScene, LightSampler, RenderSettings, Session};
use crate::scene::{Camera, Scene};
use camera::FlyCamera;
use display::Display;

/// What `preview` is asked for.
#[derive(Clone, Debug)]
pub struct PreviewRequest {
    pub scene: Option<PathBuf>,
    pub sampler: LightSampler,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub max_depth: u32,
    /// `--light-point`: how a point on a triangle light is drawn.
    pub light_point: crate::lights::LightPoint,
    /// `--stratify`: the passes' numbers.
    pub stratify: crate::render::Stratify,
    pub regions: RegionSettings,
    pub learn: LearnSettings,
    pub device: ContextOptions,
}

const NO_DISPLAY: &str = "the preview needs a display (DISPLAY or WAYLAND_DISPLAY) and none can be opened; `lightlearn render` is the headless path";

/// Frames aim at this many seconds of passes while the camera moves, so input stays
/// responsive (one pass is the smallest unit: at depth 8 on lavapipe even a reduced pass can
/// take longer), and at rest, where fewer presents leave more time to the passes.
const MOVING_FRAME_SECONDS: f64 = 1.0 / 30.0;
const RESTING_FRAME_SECONDS: f64 = 1.0 / 10.0;
/// The camera counts as moving for this long after the last change: the film stays at
/// reduced size meanwhile.
const REST_SECONDS: f64 = 0.3;
/// ±20 stops: past any image's range, and 2^±20 stays a normal float.
const MAX_HALF_STOPS: i32 = 40;

/// Opens the window and runs until Esc or the window is closed.
pub fn run(req: &PreviewRequest, ui: &mut dyn Ui) -> Result<()> {
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        bail!("{NO_DISPLAY}");
    }
    crate::commands::check_depth(req.max_depth)?;
    req.regions.check()?;
    req.learn.check()?;
    let scene = crate::commands::load_scene(req.scene.as_deref(), ui)?;
    let bvh = Bvh::build(&scene.triangles);
    let started = Instant::now();
    let (event_loop, note) = window_system::event_loop(NO_DISPLAY)?;
    if let Some(note) = note {
        ui.message(&format!("warning: {note}"));
    }
    let name = req
        .scene
        .as_ref()
        .and_then(|p| p.file_name())
        .map_or("default scene".to_string(), |n| {
            n.to_string_lossy().to_string()
        });
    #[allow(deprecated)] // created before run_app so that the sessions can borrow the scene
    let window = event_loop
        .create_window(
            Window::default_attributes()
                .with_title(format!("lightlearn — {name}"))
                .with_inner_size(PhysicalSize::new(req.width, req.height)),
        )
        .map_err(|e| anyhow!("cannot open a window: {e}; {NO_DISPLAY}"))?;
    let display_handle = window.display_handle()?.as_raw();
    let window_handle = window.window_handle()?.as_raw();
    let extensions = ash_window::enumerate_required_extensions(display_handle).map_err(|e| {
        anyhow!("this window system has no Vulkan surface support ({e}); {NO_DISPLAY}")
    })?;
    let ctx = Context::new_presenting(&req.device, extensions, &|entry, instance| {
        unsafe { ash_window::create_surface(entry, instance, display_handle, window_handle, None) }
            .map_err(|e| anyhow!("cannot create a Vulkan surface for the window: {e}"))
    })?;
    let gpu = GpuScene::upload(&ctx, &scene, &bvh)?;
    let size = window.inner_size();
    let display = Display::new(&ctx, size.width, size.height)?;
    ui.message(&format!(
        "{}: {} triangles, {}; device {}",
        scene.source,
        scene.triangles.len(),
        scene.lights_summary(),
        ctx.describe()
    ));
    let (lo, hi) = scene.bounds();
    let extent = (hi - lo).length().max(1e-3);
    let mut app = App {
        req: req.clone(),
        name,
        ctx: ctx.clone(),
        scene: &scene,
        gpu: &gpu,
        window: &window,
        display,
        sessions: HashMap::new(),
        sampler: req.sampler,
        depth: req.max_depth,
        camera: FlyCamera::from_camera(&scene.camera, 0.25 * extent),
        view: scene.camera,
        centre: 0.5 * (lo + hi),
        bounds: (lo, hi),
        half_stops: 0,
        display_mode: 0,
        heat: None,
        pivot: 0.5 * (lo + hi),
        held: HashSet::new(),
        tapped: HashSet::new(),
        cursor: None,
        buttons: (false, false),
        last_change: None,
        last_frame: Instant::now(),
        frame_seconds: 0.0,
        per_pass: None,
        move_factor: if req.max_depth > 1 { 4 } else { 2 },
        started,
        first_image: None,
        title_at: Instant::now(),
        error: None,
        ui,
    };
    event_loop.run_app(&mut app)?;
    if let Some(t) = app.first_image {
        app.ui.message(&format!("first image after {t:.2} s"));
    }
    match app.error.take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App<'a, 'u> {
    /// Dropped first (fields drop in order): the sessions and the swapchain go before the
    /// context's surface, and the window (a local of `run`) outlives them all.
    sessions: HashMap<(LightSampler, u32), Session<'a>>,
    display: Display,
    req: PreviewRequest,
    name: String,
    ctx: Arc<Context>,
    scene: &'a Scene,
    gpu: &'a GpuScene,
    window: &'a Window,
    sampler: LightSampler,
    depth: u32,
    /// The controller; `view` is the camera rendered (exactly the scene's until the first
    /// move, so an unmoved preview is the `render` of its camera).
    camera: FlyCamera,
    view: Camera,
    centre: Vec3,
    bounds: (Vec3, Vec3),
    /// The exposure in half stops (+/-), within ±MAX_HALF_STOPS: a factor kept as a float
    /// reached 0 after ~320 presses of - (and ∞ after ~270 of +), from which no key brought
    /// the image back (an audit, 2026-12-07).
    half_stops: i32,
    /// 0: the image; 1: relative error; 2: zero-light-sample share; 3: what each region
    /// has learned (computed on the host, refreshed twice a second, and within 0.1 s of a
    /// camera change).
    display_mode: u32,
    /// The heat map: when, from which camera, its pixels.
    heat: Option<(Instant, Camera, Vec<u32>)>,
    /// What a left-drag orbits: the point under the cursor when the button went down.
    pivot: Vec3,
    held: HashSet<KeyCode>,
    /// Keys pressed since the last frame, released or not: a tap shorter than a frame (a
    /// path-traced pass takes over a second on lavapipe) still moves the camera by one
    /// frame's step. Before, a W pressed and released between two frames did nothing
    /// (tests/preview.rs taps W with `xdotool key w`: 2 of 2 runs failed without this).
    tapped: HashSet<KeyCode>,
    cursor: Option<(f64, f64)>,
    /// Left, right mouse buttons.
    buttons: (bool, bool),
    /// When the camera last changed (None: at rest since the start).
    last_change: Option<Instant>,
    last_frame: Instant,
    frame_seconds: f64,
    /// Seconds per pass of the current session at its current size.
    per_pass: Option<f64>,
    /// How much smaller than the window the film is while the camera moves: 2 to start (4
    /// with paths), doubled (up to 8) while one pass at that size takes longer than 1/20 s
    /// (the 15 frames per second the preview aims at, with the display's share).
    move_factor: u32,
    started: Instant,
    first_image: Option<f64>,
    title_at: Instant,
    error: Option<anyhow::Error>,
    ui: &'u mut dyn Ui,
}

impl<'a> App<'a, '_> {
    fn settings(&self, width: u32, height: u32) -> RenderSettings {
        RenderSettings {
            width,
            height,
            budget: Budget::Samples(u32::MAX),
            seed: self.req.seed,
            sampler: self.sampler,
            regions: self.req.regions,
            learn: self.req.learn,
            resume: None,
            stratify: self.req.stratify,
            max_depth: self.depth,
            light_point: self.req.light_point,
            indirect_light_samples: 1,
            first_light_samples: 1,
        }
    }

    fn moving(&self) -> bool {
        self.last_change
            .is_some_and(|t| t.elapsed().as_secs_f64() < REST_SECONDS)
    }

    /// The film size now: the window's, or 1/`move_factor` of it while the camera moves.
    fn film_size(&self) -> (u32, u32) {
        let (w, h) = self.display.extent();
        let mut f = if self.moving() { self.move_factor } else { 1 };
        // A window larger than the device's film (lavapipe: 4.2 M pixels, 128 MiB of
        // accumulators) renders a smaller film, shown scaled as while moving: a maximised
        // window of 3000×1500 ended the preview (an audit, 2026-12-06).
        let most = render::max_film_pixels(&self.ctx);
        let fits = |f: u32| {
            let (a, b) = ((w / f).max(1) as u64, (h / f).max(1) as u64);
            a * b <= most
                && a <= crate::commands::MAX_SIZE as u64
                && b <= crate::commands::MAX_SIZE as u64
        };
        while !fits(f) {
            f += 1;
        }
        ((w / f).max(1), (h / f).max(1))
    }

    /// The exposure as a linear factor.
    fn exposure(&self) -> f32 {
        2f32.powf(self.half_stops as f32 / 2.0)
    }

    /// The current session, made on first use, at the current camera and film size.
    fn session(&mut self) -> Result<&mut Session<'a>> {
        let key = (self.sampler, self.depth);
        let (w, h) = self.film_size();
        if !self.sessions.contains_key(&key) {
            let s = Session::new(&self.ctx, self.scene, self.gpu, &self.settings(w, h))?;
            self.sessions.insert(key, s);
            self.per_pass = None;
        }
        // Only the session shown keeps its scratch buffers (Session::release_scratch).
        for (k, s) in self.sessions.iter_mut() {
            if *k != key {
                s.release_scratch();
            }
        }
        let camera = self.view;
        let session = self.sessions.get_mut(&key).expect("inserted above");
        let (_, fw, fh) = session.film();
        if (fw, fh) != (w, h) {
            session.resize(w, h)?;
            self.per_pass = None;
        }
        if session.camera() != camera {
            session.set_camera(camera)?;
        }
        Ok(session)
    }

    /// The scene point under the cursor (the scene centre when it points at nothing).
    fn point_under_cursor(&self) -> Vec3 {
        let (w, h) = self.display.extent();
        let Some((x, y)) = self.cursor else {
            return self.centre;
        };
        let d = heat::pixel_ray(&self.view, w, h, x as f32, y as f32);
        match self
            .gpu
            .bvh
            .intersect(self.view.position, d, 0.0, f32::INFINITY)
        {
            Some((t, _)) => self.view.position + t * d,
            None => self.centre,
        }
    }

    /// The controller moved: render its camera.
    fn changed_camera(&mut self) {
        self.view = self.camera.camera();
        self.last_change = Some(Instant::now());
    }

    fn frame(&mut self) -> Result<()> {
        let size = self.window.inner_size();
        if size.width == 0 || size.height == 0 {
            // Minimised: nothing to show, and a 0×0 swapchain is invalid.
            return Ok(());
        }
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f64().min(0.25) as f32;
        self.last_frame = now;
        // Held keys, and keys tapped since the last frame, fly and look.
        let mut amount = Vec3::ZERO;
        let (mut yaw, mut pitch) = (0.0, 0.0);
        for k in self.held.union(&self.tapped) {
            match k {
                KeyCode::KeyW => amount.x += 1.0,
                KeyCode::KeyS => amount.x -= 1.0,
                KeyCode::KeyD => amount.y += 1.0,
                KeyCode::KeyA => amount.y -= 1.0,
                KeyCode::KeyE => amount.z += 1.0,
                KeyCode::KeyQ => amount.z -= 1.0,
                KeyCode::ArrowLeft => yaw += 1.0,
                KeyCode::ArrowRight => yaw -= 1.0,
                KeyCode::ArrowUp => pitch += 1.0,
                KeyCode::ArrowDown => pitch -= 1.0,
                _ => {}
            }
        }
        self.tapped.clear();
        if amount != Vec3::ZERO || yaw != 0.0 || pitch != 0.0 {
            self.camera.fly(amount, dt);
            self.camera.look(yaw * dt, pitch * dt);
            self.changed_camera();
        }
        // Passes for about a frame's time (at least one), timed at the film's current size
        // (session() forgets the timing when it resizes the film).
        let moving = self.moving();
        let target = if moving {
            MOVING_FRAME_SECONDS
        } else {
            RESTING_FRAME_SECONDS
        };
        self.session()?;
        let k = self
            .per_pass
            .map_or(1, |p| ((target / p.max(1e-6)) as u32).clamp(1, 64));
        let session = self
            .sessions
            .get_mut(&(self.sampler, self.depth))
            .expect("made by session()");
        // Cuts for newly reached regions are built once the camera rests (building them
        // every frame while moving took half of each frame on lavapipe).
        session.pause_growth(moving);
        // A full film ([`render::MAX_FILM_SPP`]: a small window after ~20 minutes) stays as it
        // is; more passes would have darkened it.
        let k = k.min(render::MAX_FILM_SPP.saturating_sub(session.spp()));
        if k == 0 {
            // Nothing to add: a frame's rest instead of presenting the same image flat out.
            std::thread::sleep(std::time::Duration::from_secs_f64(RESTING_FRAME_SECONDS));
        } else {
            let seconds = session.run_passes(k)?;
            self.per_pass = Some(seconds / k as f64);
            if moving && seconds / k as f64 > 1.0 / 20.0 && self.move_factor < 8 {
                self.move_factor *= 2;
            }
        }
        let (exposure, view) = (self.exposure(), self.display_mode);
        let session = &self.sessions[&(self.sampler, self.depth)];
        let spp = session.spp();
        let (_, fw, fh) = session.film();
        let regions = session.regions_with_cuts();
        let presented = if view == 3 {
            // Refreshed twice a second as the learning goes on, and soon after the camera
            // moves: before, the map of the old view stayed over the new one for up to half a
            // second. Not every frame while moving: a 640×480 map is ~0.3 M CPU rays.
            let stale = self.heat.as_ref().is_none_or(|(t, camera, px)| {
                let age = t.elapsed().as_secs_f64();
                age > 0.5
                    || (*camera != self.view && age > 0.1)
                    || px.len() != (self.display.extent().0 * self.display.extent().1) as usize
            });
            if stale {
                let (w, h) = self.display.extent();
                let px = heat::heat_map(
                    self.scene,
                    self.gpu,
                    &self.view,
                    session,
                    w,
                    h,
                    self.display.bgra(),
                )?;
                self.heat = Some((Instant::now(), self.view, px));
            }
            let px = &self.heat.as_ref().expect("made above").2;
            self.display.show_pixels(px)?
        } else {
            self.display.show(session, exposure, view)?
        };
        if presented == Presented::OutOfDate {
            let s = self.window.inner_size();
            self.display.resize(s.width, s.height)?;
        }
        if self.first_image.is_none() {
            self.first_image = Some(self.started.elapsed().as_secs_f64());
        }
        self.frame_seconds = now.elapsed().as_secs_f64();
        if self.title_at.elapsed().as_secs_f64() > 0.25 {
            self.title_at = Instant::now();
            let msps = fw as f64 * fh as f64 / self.per_pass.unwrap_or(1.0).max(1e-9) / 1e6;
            self.window.set_title(&format!(
                "lightlearn — {} — {} {} — {spp} spp at {fw}×{fh}, {msps:.2} Msamples/s, {:.0} ms/frame, {regions} regions learned{}{}{}",
                self.name,
                self.sampler.name(),
                if self.depth > 1 { format!("paths (depth {})", self.depth) } else { "direct light".into() },
                self.frame_seconds * 1e3,
                if spp >= render::MAX_FILM_SPP { " — the film is full" } else { "" },
                match self.half_stops {
                    0 => String::new(),
                    h => format!(" — exposure {:+} EV", h as f32 / 2.0),
                },
                [" — image", " — relative error", " — zero light samples", " — regions learned"][view as usize]
            ));
        }
        Ok(())
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }
}

impl ApplicationHandler for App<'_, '_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        event_loop.set_control_flow(ControlFlow::Poll);
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if self.error.is_some() {
            // Exiting: events still queued must not touch a state that failed.
            return;
        }
        let result = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::Resized(size) => self.display.resize(size.width, size.height),
            WindowEvent::RedrawRequested => self.frame(),
            WindowEvent::KeyboardInput {
                event,
                is_synthetic,
                ..
            } => {
                let PhysicalKey::Code(code) = event.physical_key else {
                    return;
                };
                match event.state {
                    // A synthetic press is winit's note, as the window gains focus, of a key
                    // down at that moment: held (W keeps flying), not pressed again. Acted
                    // on, it repeated a press whose real event was still queued (P just
                    // after a focus change saved two screenshots; tests/preview.rs saw the
                    // second one's report in place of the next P's, once in ~10 runs) and
                    // acted on keys pressed outside the window.
                    ElementState::Pressed if is_synthetic => {
                        self.held.insert(code);
                        Ok(())
                    }
                    ElementState::Pressed => {
                        self.held.insert(code);
                        self.tapped.insert(code);
                        if event.repeat {
                            Ok(())
                        } else {
                            self.key(code, event_loop)
                        }
                    }
                    ElementState::Released => {
                        self.held.remove(&code);
                        Ok(())
                    }
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => {
                        if down && !self.buttons.0 {
                            self.pivot = self.point_under_cursor();
                        }
                        self.buttons.0 = down
                    }
                    MouseButton::Right => self.buttons.1 = down,
                    _ => {}
                }
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let Some(prev) = self.cursor {
                    let (dx, dy) = ((p.0 - prev.0) as f32, (p.1 - prev.1) as f32);
                    const RAD_PER_PIXEL: f32 = 0.005;
                    if self.buttons.0 {
                        self.camera
                            .orbit(self.pivot, -dx * RAD_PER_PIXEL, -dy * RAD_PER_PIXEL);
                        self.changed_camera();
                    } else if self.buttons.1 {
                        self.camera.look(-dx * RAD_PER_PIXEL, -dy * RAD_PER_PIXEL);
                        self.changed_camera();
                    }
                }
                self.cursor = Some(p);
                Ok(())
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                // Within 10⁻⁴…10⁴ of the starting speed: 420 notches up made it infinite and
                // the next move ended the preview ("a camera needs a finite position"), ~450
                // down made it 0 for good (an audit, 2026-12-06).
                let start = 0.25 * (self.bounds.1 - self.bounds.0).length().max(1e-3);
                self.camera.speed =
                    (self.camera.speed * 1.25f32.powf(lines)).clamp(1e-4 * start, 1e4 * start);
                Ok(())
            }
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        self.window.request_redraw();
    }
}
