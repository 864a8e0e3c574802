//! The render session's two kernels and their bindings: `render.comp` (one progressive pass)
//! and `fold.comp` (a learning window into the posteriors), bound by descriptor set to the
//! session's three lifetimes, and the command sequence of passes with their folds. The
//! session (session.rs) decides what runs when; this module records it.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;

use super::learned_state::LearnedState;
use super::{GpuScene, RenderSettings};
use crate::gpu::layout::RenderParams;
use crate::gpu::{kernels, Buffer, ComputePipeline, Context};

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
    ],
    &["Accum", "Counters"],
];
const SCENE_SET: usize = 0;
const LEARNED_SET: usize = 1;
const FILM_SET: usize = 2;

/// The storage blocks of `fold.comp` by binding number (set 0).
pub const FOLD_BINDINGS: [&str; 4] = ["Stats", "Delta", "Learn", "Touched"];

/// fold.comp's modes (its push constant `mode`): the slots the window listed (between
/// passes, an indirect dispatch), or every slot with its coefficients recomputed.
const FOLD_TOUCHED: u32 = 0;
const FOLD_ALL: u32 = 1;

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

/// The session's two kernels, bound to its buffers.
pub(super) struct PassKernels {
    render: ComputePipeline,
    fold: ComputePipeline,
}

impl PassKernels {
    pub(super) fn new(
        ctx: &Arc<Context>,
        gpu: &GpuScene,
        settings: &RenderSettings,
    ) -> Result<Self> {
        Ok(PassKernels {
            render: render_pipeline(ctx, gpu, settings, 0)?,
            fold: ComputePipeline::new(
                ctx,
                "fold",
                kernels::FOLD,
                FOLD_BINDINGS.len() as u32,
                8,
                &[],
            )?,
        })
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

    /// Binds the scene's buffers (once).
    pub(super) fn bind_scene(&self, g: &GpuScene) -> Result<()> {
        let scene: [(&str, &Buffer); 13] = [
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
        ];
        let set = in_binding_order(&scene, RENDER_BINDINGS[SCENE_SET]);
        self.render.bind_set(SCENE_SET, &set)
    }

    /// Binds the learned state's buffers (again when cuts were added).
    pub(super) fn bind_learned(&self, l: &LearnedState) -> Result<()> {
        let learned: [(&str, &Buffer); 8] = [
            ("grid_texels", &l.grid),
            ("region_index_texels", &l.index),
            ("cut_texels", &l.cuts_buf),
            ("slot_stat_texels", &l.stats),
            ("Delta", &l.delta),
            ("Learn", &l.params),
            ("MissingRegions", &l.missing),
            ("Touched", &l.touched),
        ];
        let set = in_binding_order(&learned, RENDER_BINDINGS[LEARNED_SET]);
        self.render.bind_set(LEARNED_SET, &set)?;
        let fold: [(&str, &Buffer); 4] = [
            ("Stats", &l.stats),
            ("Delta", &l.delta),
            ("Learn", &l.params),
            ("Touched", &l.touched),
        ];
        self.fold.bind(&in_binding_order(&fold, &FOLD_BINDINGS))
    }

    /// Binds the film's buffers (again after a resize).
    pub(super) fn bind_film(&self, accum: &Buffer, counters: &Buffer) -> Result<()> {
        let film: [(&str, &Buffer); 2] = [("Accum", accum), ("Counters", counters)];
        let set = in_binding_order(&film, RENDER_BINDINGS[FILM_SET]);
        self.render.bind_set(FILM_SET, &set)
    }

    /// Folds the window into the totals and recomputes every slot's coefficients (fresh or
    /// loaded statistics, new slots); between passes the fold visits the touched slots alone
    /// ([`PassKernels::submit`]).
    pub(super) fn fold_all(&self, ctx: &Context, slots: u32) -> Result<()> {
        let push = [slots, FOLD_ALL];
        let groups = [slots.div_ceil(64), 1, 1];
        ctx.submit(|cmd| self.fold.dispatch(cmd, bytemuck::cast_slice(&push), groups))
    }

    /// `k` passes of a `width`×`height` film in one submission, from learning pass
    /// `params.sample_index` on; with `fold_every` (the learned samplers' --update-every)
    /// the touched slots of `learned` are folded after every pass that ends a window.
    /// Returns their seconds.
    pub(super) fn submit(
        &self,
        ctx: &Context,
        mut params: RenderParams,
        k: u32,
        fold_every: Option<u32>,
        learned: &LearnedState,
    ) -> Result<f64> {
        let first = params.sample_index;
        let groups = [params.width.div_ceil(8), params.height.div_ceil(8), 1];
        let fold_push = [learned.slots, FOLD_TOUCHED];
        let t0 = Instant::now();
        ctx.submit(|cmd| {
            for i in 0..k {
                params.sample_index = first + i;
                self.render
                    .dispatch(cmd, bytemuck::bytes_of(&params), groups);
                ctx.barrier(cmd);
                if fold_every.is_some_and(|every| (params.sample_index + 1).is_multiple_of(every)) {
                    // As many workgroups as the pass listed touched slots (render.comp).
                    self.fold.dispatch_indirect(
                        cmd,
                        bytemuck::cast_slice(&fold_push),
                        &learned.touched,
                        0,
                    );
                    ctx.barrier(cmd);
                }
            }
        })?;
        Ok(t0.elapsed().as_secs_f64())
    }
}

/// `render.comp` for these settings, with the stages in `knock_out` left out (0: none).
fn render_pipeline(
    ctx: &Arc<Context>,
    gpu: &GpuScene,
    settings: &RenderSettings,
    knock_out: u32,
) -> Result<ComputePipeline> {
    ComputePipeline::with_sets(
        ctx,
        "render",
        kernels::RENDER,
        &RENDER_BINDINGS.map(|set| set.len() as u32),
        std::mem::size_of::<RenderParams>() as u32,
        &[
            settings.sampler.shader_id(),
            settings.regions.in_cluster_importance as u32,
            knock_out,
            settings.learn.gpu_params().flags,
            gpu.kernel_flags,
            (settings.max_depth == 1) as u32,
        ],
    )
}
