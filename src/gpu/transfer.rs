//! Transfers batched into one submission: uploads and clears recorded together, followed by
//! whatever dispatches the caller records, and read-backs of several buffers at once.
//! Why: every synchronous submission waits for the device; an empty one took 0.55–0.57 ms on
//! an NVIDIA H200 (and 0.04 ms on lavapipe), so a step that made each upload, clear and
//! read-back its own submission paid that six to eleven times (docs/results.md, 2026-12-04,
//! fifth session).

use std::sync::Arc;

use anyhow::Result;
use ash::vk;
use gpu_allocator::MemoryLocation;

use super::buffer::Buffer;
use super::context::Context;

/// Where each staged piece starts: 16-byte steps keep every copy's source aligned for any
/// element type the host reads back.
const ALIGN: usize = 16;

enum Op {
    /// Staging bytes `at..at + size` to `dst` at `offset`.
    Write {
        dst: vk::Buffer,
        offset: u64,
        at: u64,
        size: u64,
    },
    /// `dst` filled with zeros.
    Clear { dst: vk::Buffer },
}

/// Uploads and clears to submit together ([`Transfers::submit`]), in the order recorded. The
/// buffers they name must stay alive until then (they are recorded by handle).
#[derive(Default)]
pub struct Transfers {
    staging: Vec<u8>,
    ops: Vec<Op>,
}

impl Transfers {
    pub fn new() -> Transfers {
        Transfers::default()
    }

    /// Nothing recorded.
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// `bytes` into `dst` at byte `offset`.
    pub fn write(&mut self, dst: &Buffer, offset: u64, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        assert!(
            offset + bytes.len() as u64 <= dst.size,
            "write past the end of a buffer"
        );
        let at = self.staging.len().next_multiple_of(ALIGN);
        self.staging.resize(at, 0);
        self.staging.extend_from_slice(bytes);
        self.ops.push(Op::Write {
            dst: dst.raw,
            offset,
            at: at as u64,
            size: bytes.len() as u64,
        });
    }

    /// `dst` filled with zeros.
    pub fn clear(&mut self, dst: &Buffer) {
        self.ops.push(Op::Clear { dst: dst.raw });
    }

    /// One submission: the recorded uploads and clears, a barrier, then what `then` records
    /// (dispatches that read what was written).
    pub fn submit(self, ctx: &Arc<Context>, then: impl FnOnce(vk::CommandBuffer)) -> Result<()> {
        let staging = if self.staging.is_empty() {
            None
        } else {
            let mut s = Buffer::new(
                ctx,
                "staging upload",
                self.staging.len() as u64,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?;
            s.mapped_mut()?[..self.staging.len()].copy_from_slice(&self.staging);
            Some(s)
        };
        ctx.submit(|cmd| {
            // Earlier submissions' writes (kernels) before these overwrite or clear them.
            ctx.barrier(cmd);
            for op in &self.ops {
                match *op {
                    Op::Write {
                        dst,
                        offset,
                        at,
                        size,
                    } => {
                        let region = [vk::BufferCopy::default()
                            .src_offset(at)
                            .dst_offset(offset)
                            .size(size)];
                        let src = staging.as_ref().expect("staged bytes").raw;
                        unsafe { ctx.device.cmd_copy_buffer(cmd, src, dst, &region) };
                    }
                    Op::Clear { dst } => unsafe {
                        ctx.device.cmd_fill_buffer(cmd, dst, 0, vk::WHOLE_SIZE, 0)
                    },
                }
            }
            ctx.barrier(cmd);
            then(cmd);
        })
    }
}

/// The first `bytes` of each buffer, read back in one submission.
pub fn read_many(ctx: &Arc<Context>, reads: &[(&Buffer, u64)]) -> Result<Vec<Vec<u8>>> {
    let mut at = Vec::with_capacity(reads.len());
    let mut total = 0usize;
    for &(buf, bytes) in reads {
        assert!(bytes <= buf.size, "read past the end of a buffer");
        total = total.next_multiple_of(ALIGN);
        at.push(total);
        total += bytes as usize;
    }
    let staging = Buffer::new(
        ctx,
        "staging readback",
        total.max(4) as u64,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    ctx.submit(|cmd| {
        // The writes of earlier submissions (kernels, transfers) before the copies read them.
        ctx.barrier(cmd);
        for (&(buf, bytes), &a) in reads.iter().zip(&at) {
            if bytes == 0 {
                continue;
            }
            let region = [vk::BufferCopy::default().dst_offset(a as u64).size(bytes)];
            unsafe {
                ctx.device
                    .cmd_copy_buffer(cmd, buf.raw, staging.raw, &region)
            };
        }
        ctx.host_read_barrier(cmd);
    })?;
    let mapped = staging.mapped()?;
    Ok(reads
        .iter()
        .zip(&at)
        .map(|(&(_, bytes), &a)| mapped[a..a + bytes as usize].to_vec())
        .collect())
}

/// `bytes` (a whole number of `T`s) as `T`s; a read-back's bytes may not be aligned for `T`.
pub fn pod_vec<T: bytemuck::Pod>(bytes: &[u8]) -> Vec<T> {
    bytes
        .chunks_exact(std::mem::size_of::<T>())
        .map(bytemuck::pod_read_unaligned)
        .collect()
}
