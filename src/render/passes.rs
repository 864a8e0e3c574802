//! The render session's two kernels and their bindings: `render.comp` (one progressive pass)
//! and `fold.comp` (a learning window into the posteriors), bound by descriptor set to the
//! session's three lifetimes, and the command sequence of passes with their folds. The
//! session (session/mod.rs) decides what runs when; this module records it.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;

use super::learned_state::LearnedState;
use super::timeline::Event;
use super::{GpuScene, LightPoint, RenderSettings};
use crate::gpu::layout::{FoldPush, RenderParams};
use crate::gpu::{kernels, Buffer, ComputePipeline, Context, Transfers};
use crate::learning::{LearningClock, UpdateEvery};

/// The bindings of `render.comp` by descriptor set and binding number, as the kernel names
/// them (a storage buffer by its block, a texel buffer by its variable, `…_texels`: made by
/// `Buffer::texels` or `Buffer::words`); sets follow the lifetimes: the scene, the learned
/// state, the film. `tests/layout.rs` reads the names and numbers from the compiled SPIR-V
/// and checks them.
pub const RENDER_BINDINGS: [&[&str]; 3] = [
    &[
        "bvh_node_texels",
        "bvh_tri_texels",
        "TriMaterial",
        "material_texels",
        "light_texels",
        "Alias",
        "light_node_texels",
        "LightOrder",
        "LightPosition",
        "TriLight",
        "Textures",
        "Texels",
        "TriUv",
        "layer_albedo_texels",
    ],
    &[
        "grid_texels",
        "region_index_texels",
        "cut_texels",
        "slot_stat_texels",
        "Delta",
        "Learn",
        "MissingRegions",
        "Touched",
        "SideCounts",
    ],
    &[
        "accum_texels",
        "Counters",
        "QueueHeads",
        "path_texels",
        "path_image",
        "LiveRows",
        "accum_image",
    ],
];
const SCENE_SET: usize = 0;
const LEARNED_SET: usize = 1;
const FILM_SET: usize = 2;

/// The bindings of `fold.comp` by number (set 0): storage blocks by block name, texel
/// buffers by variable name.
pub const FOLD_BINDINGS: [&str; 6] = [
    "Stats",
    "Delta",
    "Touched",
    "prior_texels",
    "stat_texels",
    "delta_texels",
];

/// fold.comp's modes (its push constant `mode`): the slots the window listed (between
/// passes, an indirect dispatch), or every slot with its coefficients recomputed.
const FOLD_TOUCHED: u32 = 0;
const FOLD_ALL: u32 = 1;

/// fold.comp's push constants for `learned` in `mode` (from slot `first` under FOLD_ALL).
fn fold_push(learned: &LearnedState, mode: u32, first: u32) -> FoldPush {
    FoldPush {
        slot_count: learned.slots,
        mode,
        first,
        learn: learned.learn,
    }
}

/// The buffers of `named` in the order of `bindings` (each name once).
fn in_binding_order<'b>(named: &[(&str, &'b Buffer)], bindings: &[&str]) -> Vec<&'b Buffer> {
    bindings
        .iter()
        .map(|b| {
            named
                .iter()
                .find(|(n, _)| n == b)
                .map(|(_, buf)| *buf)
                .expect("every binding has a buffer")
        })
        .collect()
}

/// RGBA32UI texels of one path in the wavefront's queues (shaders/shared/path_queue.glsl
/// PATH_TEXELS; a host that allotted fewer would make the paths past the end of the buffer
/// lose their state: the golden renders of tests/golden_pixels.rs would change).
const PATH_TEXELS: u64 = 10;
/// The wavefront's queue buffer holds at most this many bytes (both queues) by default: a
/// film with more paths is started in bands of rows, one after the other, each traced to its
/// end (640×480 in two bands; [`PassKernels::set_queue_bytes`] changes it).
pub const QUEUE_BYTES: u64 = 64 << 20;

/// The wavefront's two path queues for a film, and the bands of rows that fill them.
struct PathQueues {
    /// Each queue's indirect dispatch (workgroups, 1, 1) and its length: 8 u32.
    heads: Buffer,
    /// Both queues' paths, `cap` each.
    paths: Buffer,
    /// Paths per queue: `rows` × the film's width.
    cap: u32,
    /// Film rows started per band (a multiple of 8, the workgroup's height).
    rows: u32,
}

impl PathQueues {
    /// Queues for a `width`×`height` film, or one path's worth where the kernel traces
    /// every vertex in one dispatch (the set must be bound either way).
    fn new(
        ctx: &Arc<Context>,
        width: u32,
        height: u32,
        wavefront: bool,
        bytes: u64,
    ) -> Result<Self> {
        let path_bytes = 16 * PATH_TEXELS;
        let (rows, cap) = if wavefront {
            let limits = &ctx.properties.limits;
            let budget = bytes
                .min(limits.max_storage_buffer_range as u64)
                .min(16 * limits.max_texel_buffer_elements as u64);
            let max_rows = (budget / (2 * path_bytes * width as u64)) / 8 * 8;
            if max_rows == 0 {
                anyhow::bail!(
                    "a film {width} pixels wide needs {} bytes of path queues for 8 rows, more than the {budget} bytes allowed; render a narrower image",
                    16 * path_bytes * width as u64
                );
            }
            let bands = (height as u64).div_ceil(max_rows);
            let rows = (height as u64).div_ceil(bands).div_ceil(8) * 8;
            (rows as u32, (rows * width as u64) as u32)
        } else {
            (height.div_ceil(8) * 8, 1)
        };
        Ok(PathQueues {
            heads: Buffer::zeroed_indirect(ctx, "path queue heads", 32)?,
            paths: Buffer::scratch_texels(ctx, "path queues", 2 * cap as u64 * path_bytes)?,
            cap,
            rows,
        })
    }

    /// Records the reset of queue `q` (empty, its dispatch 0 workgroups).
    fn reset(&self, cmd: ash::vk::CommandBuffer, q: u32) {
        let empty: [u32; 4] = [0, 1, 1, 0];
        self.heads
            .record_write(cmd, 16 * q as u64, bytemuck::cast_slice(&empty));
    }
}

/// The session's two kernels, bound to its buffers.
pub(super) struct PassKernels {
    render: ComputePipeline,
    fold: ComputePipeline,
    /// Paths are traced one bounce per dispatch (render.comp WAVEFRONT): path tracing.
    wavefront: bool,
    queues: Option<PathQueues>,
    /// The most bytes the path queues may take ([`QUEUE_BYTES`] by default).
    queue_bytes: u64,
    /// Direct light: the rows of 8 pixels its dispatch covers (render.comp `LiveRows`: their
    /// count, then the rows; [`super::coverage`]) and their count.
    live: Option<(Buffer, u32)>,
}

impl PassKernels {
    pub(super) fn new(
        ctx: &Arc<Context>,
        gpu: &GpuScene,
        settings: &RenderSettings,
    ) -> Result<Self> {
        Ok(PassKernels {
            wavefront: wavefront(settings),
            queues: None,
            queue_bytes: QUEUE_BYTES,
            live: None,
            render: render_pipeline(ctx, gpu, settings, 0)?,
            fold: ComputePipeline::new(
                ctx,
                "fold",
                kernels::FOLD,
                FOLD_BINDINGS.len() as u32,
                std::mem::size_of::<FoldPush>() as u32,
                &[],
            )?,
        })
    }

    /// The most bytes the wavefront's path queues may take (the next [`Self::bind_film`]
    /// makes them): fewer bands of rows for more memory, the same image either way.
    /// Returns the limit before.
    pub(super) fn set_queue_bytes(&mut self, bytes: u64) -> u64 {
        std::mem::replace(&mut self.queue_bytes, bytes)
    }

    /// Rebuilds the render kernel with the stages in `mask` knocked out (0: none); the
    /// caller binds its sets again.
    pub(super) fn knock_out(
        &mut self,
        ctx: &Arc<Context>,
        gpu: &GpuScene,
        settings: &RenderSettings,
        mask: u32,
    ) -> Result<()> {
        self.render = render_pipeline(ctx, gpu, settings, mask)?;
        Ok(())
    }

    /// Whether a pass is one dispatch over the film's rows of 8 pixels (direct light), not
    /// the wavefront's dispatches of paths.
    pub(super) fn direct_light(&self) -> bool {
        !self.wavefront
    }

    /// The rows of 8 pixels a direct-light dispatch covers.
    pub(super) fn live_rows(&self) -> u32 {
        self.live.as_ref().map_or(0, |(_, n)| *n)
    }

    /// Binds the scene's buffers (once).
    pub(super) fn bind_scene(&self, g: &GpuScene) -> Result<()> {
        let scene: [(&str, &Buffer); 14] = [
            ("bvh_node_texels", &g.nodes),
            ("bvh_tri_texels", &g.tris),
            ("TriMaterial", &g.tri_material),
            ("material_texels", &g.materials),
            ("light_texels", &g.lights),
            ("Alias", &g.alias),
            ("light_node_texels", &g.light_nodes),
            ("LightOrder", &g.light_order),
            ("LightPosition", &g.light_position),
            ("TriLight", &g.tri_light),
            ("Textures", &g.textures),
            ("Texels", &g.texels),
            ("TriUv", &g.tri_uv),
            ("layer_albedo_texels", &g.layer_albedo),
        ];
        let set = in_binding_order(&scene, RENDER_BINDINGS[SCENE_SET]);
        self.render.bind_set(SCENE_SET, &set)
    }

    /// Binds the learned state's buffers (again when cuts were added).
    pub(super) fn bind_learned(&self, l: &LearnedState) -> Result<()> {
        let learned: [(&str, &Buffer); 9] = [
            ("grid_texels", &l.grid),
            ("region_index_texels", &l.index),
            ("cut_texels", &l.cuts_buf),
            ("slot_stat_texels", &l.stats),
            ("Delta", &l.delta),
            ("Learn", &l.params),
            ("MissingRegions", &l.missing),
            ("Touched", &l.touched),
            ("SideCounts", &l.sides),
        ];
        let set = in_binding_order(&learned, RENDER_BINDINGS[LEARNED_SET]);
        self.render.bind_set(LEARNED_SET, &set)?;
        let fold: [(&str, &Buffer); 6] = [
            ("Stats", &l.stats),
            ("Delta", &l.delta),
            ("Touched", &l.touched),
            ("prior_texels", &l.prior),
            ("stat_texels", &l.stats),
            ("delta_texels", &l.delta),
        ];
        self.fold.bind(&in_binding_order(&fold, &FOLD_BINDINGS))
    }

    /// Binds the film's buffers and makes its path queues (again after a resize); `rows`:
    /// the rows of 8 pixels direct light covers ([`super::coverage`]). On an error the
    /// binding and the queues stay as they were.
    pub(super) fn bind_film(
        &mut self,
        ctx: &Arc<Context>,
        accum: &Buffer,
        counters: &Buffer,
        width: u32,
        height: u32,
        rows: &[u32],
    ) -> Result<()> {
        let queues = PathQueues::new(ctx, width, height, self.wavefront, self.queue_bytes)?;
        let live = live_rows_buffer(ctx, rows)?;
        self.bind_film_set(accum, counters, &queues, &live.0)?;
        self.queues = Some(queues);
        self.live = Some(live);
        Ok(())
    }

    /// Frees the path queues until the next [`Self::bind_film`] makes them again.
    pub(super) fn release_queues(&mut self) {
        self.queues = None;
        // Told again by the next bind_film (the camera may move meanwhile).
        self.live = None;
    }

    /// Whether the path queues are there (the film bound and not released since).
    pub(super) fn has_queues(&self) -> bool {
        self.queues.is_some()
    }

    /// Direct light covers `rows` from the next pass on (a new camera); binds the film's
    /// buffers again with them (with the queues released, the next bind_film does). On an
    /// error the binding stays as it was.
    pub(super) fn set_live_rows(
        &mut self,
        ctx: &Arc<Context>,
        accum: &Buffer,
        counters: &Buffer,
        rows: &[u32],
    ) -> Result<()> {
        let Some(queues) = self.queues.as_ref() else {
            return Ok(());
        };
        let live = live_rows_buffer(ctx, rows)?;
        self.bind_film_set(accum, counters, queues, &live.0)?;
        self.live = Some(live);
        Ok(())
    }

    fn bind_film_set(
        &self,
        accum: &Buffer,
        counters: &Buffer,
        queues: &PathQueues,
        live: &Buffer,
    ) -> Result<()> {
        let film: [(&str, &Buffer); 7] = [
            ("accum_texels", accum),
            ("Counters", counters),
            ("QueueHeads", &queues.heads),
            ("path_texels", &queues.paths),
            ("path_image", &queues.paths),
            ("LiveRows", live),
            ("accum_image", accum),
        ];
        let set = in_binding_order(&film, RENDER_BINDINGS[FILM_SET]);
        self.render.bind_set(FILM_SET, &set)
    }

    /// Folds the window into the totals and recomputes the coefficients of the slots from
    /// `first` to `slots` (fresh or loaded statistics: all; after growth: the appended ones,
    /// as the others' totals did not change); between passes the fold visits the touched
    /// slots alone ([`PassKernels::submit`]).
    pub(super) fn fold_from(
        &self,
        ctx: &Context,
        first: u32,
        learned: &LearnedState,
    ) -> Result<()> {
        ctx.submit(|cmd| self.record_fold_from(cmd, first, learned))
    }

    fn record_fold_from(&self, cmd: ash::vk::CommandBuffer, first: u32, learned: &LearnedState) {
        let push = fold_push(learned, FOLD_ALL, first);
        let groups = [(learned.slots - first).div_ceil(64).max(1), 1, 1];
        self.fold.dispatch(cmd, bytemuck::bytes_of(&push), groups)
    }

    /// Folds the slots listed in `learned`'s touched list (a fold boundary: their windows are
    /// empty, so this recomputes their coefficients) and empties the list.
    fn record_fold_listed(&self, cmd: ash::vk::CommandBuffer, learned: &LearnedState) {
        let push = fold_push(learned, FOLD_TOUCHED, 0);
        self.fold
            .dispatch_indirect(cmd, bytemuck::bytes_of(&push), &learned.touched, 0)
    }

    /// A growth point's uploads `up` and, after them in the same submission, the fold of
    /// the slots listed in `learned`'s touched list (`listed`: the borrowed observations of
    /// those changed) and of the slots from `fold_new` on (appended: their coefficients).
    pub(super) fn submit_growth(
        &self,
        ctx: &Arc<Context>,
        up: Transfers,
        listed: bool,
        fold_new: Option<u32>,
        learned: &LearnedState,
    ) -> Result<()> {
        up.submit(ctx, |cmd| {
            if listed {
                self.record_fold_listed(cmd, learned);
                ctx.barrier(cmd);
            }
            if let Some(first) = fold_new {
                self.record_fold_from(cmd, first, learned);
            }
        })
    }

    /// `k` passes of a `width`×`height` film in one submission, from learning pass
    /// `params.sample_index` on; with `fold` (the learned samplers' --update-every and their
    /// clock before the first pass) the touched slots of `learned` are folded after every
    /// pass that ends a learning window. With `timeline` each dispatch (paths: each pass) and
    /// each fold is a submission of its own, timed into it (`profile --timeline`; the same
    /// commands, so the same image).
    /// Returns their seconds.
    pub(super) fn submit(
        &self,
        ctx: &Context,
        mut params: RenderParams,
        k: u32,
        fold: Option<(UpdateEvery, LearningClock)>,
        learned: &LearnedState,
        timeline: Option<&mut Vec<Event>>,
    ) -> Result<f64> {
        let first = params.sample_index;
        // Direct light: a workgroup takes 8 of the rows of 8 pixels that see the scene, the
        // workgroups in rows of at most MAX_GROUPS_X (Vulkan promises 65535 a dimension).
        let wgs = self.live_rows().div_ceil(8);
        let groups = [wgs.min(MAX_GROUPS_X), wgs.div_ceil(MAX_GROUPS_X), 1];
        let queues = self.queues.as_ref().expect("the film is bound");
        params.queue_cap = queues.cap;
        // The steps: (first pass, passes, whether a learning window ends after them).
        let mut steps = Vec::new();
        let mut i = 0;
        while i < k {
            // Passes this dispatch takes: direct light (render.comp main) up to about
            // 2^20 samples, so that no dispatch runs long enough for a desktop GPU's
            // watchdog, and for a learned sampler not past the end of its learning window
            // (the fold comes after); paths: one (a dispatch per bounce).
            let n = if !self.wavefront {
                let pixels = params.width * params.height;
                let n = (k - i).min((DIRECT_SAMPLES_PER_DISPATCH / pixels).max(1));
                // A learning window's passes (the statistics frozen) in one dispatch.
                match fold {
                    Some((every, clock)) => n.min(every.to_window_end(clock.after(i))),
                    None => n,
                }
            } else {
                1
            };
            let ends = fold.is_some_and(|(every, clock)| every.ends_at(clock.after(i + n)));
            steps.push((i, n, ends));
            i += n;
        }
        let record_passes = |cmd, at: u32, n: u32| {
            let mut p = params;
            p.sample_index = first + at;
            p.passes = n;
            if self.wavefront {
                self.record_wavefront(ctx, cmd, p, queues);
            } else if groups[0] > 0 {
                self.render.dispatch(cmd, bytemuck::bytes_of(&p), groups);
                ctx.barrier(cmd);
            }
        };
        let t0 = Instant::now();
        match timeline {
            None => ctx.submit(|cmd| {
                for &(at, n, ends) in &steps {
                    record_passes(cmd, at, n);
                    if ends {
                        // As many workgroups as the pass listed touched slots (render.comp).
                        self.record_fold_listed(cmd, learned);
                        ctx.barrier(cmd);
                    }
                }
            })?,
            Some(events) => {
                for &(at, n, ends) in &steps {
                    let t = Instant::now();
                    ctx.submit(|cmd| record_passes(cmd, at, n))?;
                    let render = t.elapsed().as_secs_f64();
                    let t = Instant::now();
                    let fold = if ends {
                        ctx.submit(|cmd| self.record_fold_listed(cmd, learned))?;
                        Some(t.elapsed().as_secs_f64())
                    } else {
                        None
                    };
                    events.push(Event::Passes {
                        passes: n,
                        render,
                        fold,
                    });
                }
            }
        }
        Ok(t0.elapsed().as_secs_f64())
    }
}

impl PassKernels {
    /// One pass of the wavefront: for each band of rows, a dispatch that starts its paths
    /// and takes their first vertex, then one indirect dispatch per bounce over the paths
    /// that went on (bounce d reads queue d & 1 and fills queue (d + 1) & 1).
    fn record_wavefront(
        &self,
        ctx: &Context,
        cmd: ash::vk::CommandBuffer,
        mut params: RenderParams,
        queues: &PathQueues,
    ) {
        let mut row0 = 0;
        while row0 < params.height {
            let rows = queues.rows.min(params.height - row0);
            params.row0 = row0;
            for d in 0..=params.max_depth {
                queues.reset(cmd, (d + 1) & 1);
                ctx.barrier(cmd);
                params.bounce = d;
                let push = bytemuck::bytes_of(&params);
                if d == 0 {
                    let groups = [params.width.div_ceil(8), rows.div_ceil(8), 1];
                    self.render.dispatch(cmd, push, groups);
                } else {
                    let offset = 16 * (d & 1) as u64;
                    self.render
                        .dispatch_indirect(cmd, push, &queues.heads, offset);
                }
                ctx.barrier(cmd);
            }
            row0 += rows;
        }
    }
}

/// render.comp `LiveRows`: the count of `rows`, then the rows; with the count.
fn live_rows_buffer(ctx: &Arc<Context>, rows: &[u32]) -> Result<(Buffer, u32)> {
    let count = rows.len() as u32;
    let words: Vec<u32> = std::iter::once(count).chain(rows.iter().copied()).collect();
    let live = Buffer::from_slice(ctx, "rows of pixels that see the scene", &words)?;
    Ok((live, count))
}

/// Direct light: the most workgroups along x in one dispatch (a 16384×16384 film has 2^22
/// workgroups of 8 rows of 8 pixels).
const MAX_GROUPS_X: u32 = 8192;

/// Direct light: the most samples one dispatch takes (whole passes of the film, at least
/// one). Batching passes saves lavapipe's ~0.4 ms per dispatch: rooms, `uniform`, 96×72,
/// 256 spp, 0.47 s → see docs/results.md.
const DIRECT_SAMPLES_PER_DISPATCH: u32 = 1 << 20;

/// Whether `render.comp` traces paths one bounce per dispatch (WAVEFRONT = !DIRECT_ONLY):
/// for path tracing. Direct light has one vertex, where the queues would only cost.
fn wavefront(settings: &RenderSettings) -> bool {
    settings.max_depth > 1
}

/// `render.comp` for these settings, with the stages in `knock_out` left out (0: none).
fn render_pipeline(
    ctx: &Arc<Context>,
    gpu: &GpuScene,
    settings: &RenderSettings,
    knock_out: u32,
) -> Result<ComputePipeline> {
    let direct_only = !wavefront(settings);
    ComputePipeline::with_sets(
        ctx,
        "render",
        kernels::render(settings.sampler.shader_id(), direct_only),
        &RENDER_BINDINGS.map(|set| set.len() as u32),
        std::mem::size_of::<RenderParams>() as u32,
        // Ids 0 (SAMPLER) and 5 (DIRECT_ONLY) are fixed in the kernel chosen above (their
        // values are ignored there; render.comp compiled by hand still reads them).
        &[
            settings.sampler.shader_id(),
            settings.regions.in_cluster_importance as u32,
            knock_out,
            settings.learn.gpu_params().flags,
            gpu.kernel_flags,
            // DIRECT_ONLY; render.comp derives WAVEFRONT from it.
            direct_only as u32,
            // LIGHT_POINT_SOLID_ANGLE.
            (settings.light_point == LightPoint::SolidAngle) as u32,
            // INDIRECT_LIGHT_SAMPLES.
            settings.indirect_light_samples,
            // FIRST_LIGHT_SAMPLES.
            settings.first_light_samples,
            // STRATIFY.
            settings.stratify.code(),
        ],
    )
}
