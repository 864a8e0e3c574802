//! Ray batches through `trace.comp`: the GPU side of the BVH agreement test and of the
//! ray-throughput benchmark.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;

use crate::gpu::layout::{GpuHit, GpuRay, TraceParams};
use crate::gpu::{kernels, Buffer, ComputePipeline, Context};

/// Traces `rays` against the BVH in `nodes`/`tris`; returns the hits and the fastest of
/// `repeats` timed dispatches in seconds (upload and readback excluded).
pub fn trace(
    ctx: &Arc<Context>,
    nodes: &Buffer,
    tris: &Buffer,
    rays: &[GpuRay],
    any_hit: bool,
    repeats: u32,
) -> Result<(Vec<GpuHit>, f64)> {
    let ray_buf = Buffer::from_slice(ctx, "rays", rays)?;
    let hit_buf = Buffer::zeroed(
        ctx,
        "hits",
        (rays.len() * std::mem::size_of::<GpuHit>()) as u64,
    )?;
    let pipeline = ComputePipeline::new(
        ctx,
        "trace",
        kernels::TRACE,
        4,
        std::mem::size_of::<TraceParams>() as u32,
        &[],
    )?;
    pipeline.bind(&[nodes, tris, &ray_buf, &hit_buf])?;
    let params = TraceParams {
        ray_count: rays.len() as u32,
        any_hit: any_hit as u32,
        ..Default::default()
    };
    // Rows of at most TRACE_GROUPS_X workgroups (trace.comp): a device may take no more
    // than 65535 in x (lavapipe), and `bench-rays --width 2048 --height 2048` asked 65536
    // (an audit, 2026-12-07).
    let wgs = (rays.len() as u32).div_ceil(64);
    let groups = [wgs.min(TRACE_GROUPS_X), wgs.div_ceil(TRACE_GROUPS_X), 1];
    // One untimed dispatch first: lavapipe compiles a kernel at its first dispatch, and with
    // a cold shader cache `--repeats 1` timed that compile, 20–35× below the rate (an audit,
    // 2026-12-07; `profile` does the same).
    ctx.submit(|cmd| pipeline.dispatch(cmd, bytemuck::bytes_of(&params), groups))?;
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let t0 = Instant::now();
        ctx.submit(|cmd| pipeline.dispatch(cmd, bytemuck::bytes_of(&params), groups))?;
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let hits: Vec<GpuHit> = hit_buf.read()?;
    Ok((hits[..rays.len()].to_vec(), best))
}

/// The most workgroups in a row of a trace dispatch (trace.comp numbers rays row by row).
const TRACE_GROUPS_X: u32 = 8192;
