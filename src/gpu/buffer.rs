//! Storage buffers: device-local for what kernels read and write, filled and read back
//! through host-visible staging buffers (a plain map on lavapipe's single heap, a PCIe copy on
//! a discrete GPU).

use std::sync::Arc;

use anyhow::{Context as _, Result};
use ash::vk;
use bytemuck::Pod;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::context::Context;
use super::transfer::{pod_vec, read_many, Transfers};

pub struct Buffer {
    ctx: Arc<Context>,
    pub raw: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    /// The whole buffer as texels (RGBA32UI or R32UI), for kernels that read it as a
    /// uniform texel buffer ([`Buffer::texels`], [`Buffer::words`]).
    pub view: Option<vk::BufferView>,
}

impl Buffer {
    /// A buffer of `size` bytes (at least 16: Vulkan forbids empty buffers).
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer> {
        let size = size.max(16);
        let max = ctx.properties.limits.max_storage_buffer_range as u64;
        if usage.contains(vk::BufferUsageFlags::STORAGE_BUFFER) && size > max {
            anyhow::bail!(
                "buffer '{name}' needs {size} bytes but this device allows storage buffers of at most {max}; use a smaller scene or image"
            );
        }
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let raw = unsafe { ctx.device.create_buffer(&info, None) }?;
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let allocation = ctx
            .allocator
            .lock()
            .expect("allocator")
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                unsafe { ctx.device.destroy_buffer(raw, None) };
                return Err(e)
                    .with_context(|| format!("cannot allocate {size} bytes for '{name}'"));
            }
        };
        if let Err(e) = unsafe {
            ctx.device
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        } {
            // Nothing left behind (a leak is a validation error at the context's end).
            unsafe { ctx.device.destroy_buffer(raw, None) };
            let _ = ctx.allocator.lock().map(|mut a| a.free(allocation));
            return Err(e).with_context(|| format!("cannot bind the memory of '{name}'"));
        }
        Ok(Buffer {
            ctx: ctx.clone(),
            raw,
            allocation: Some(allocation),
            size,
            view: None,
        })
    }

    /// A device-local storage buffer holding `data`.
    pub fn from_slice<T: Pod>(ctx: &Arc<Context>, name: &str, data: &[T]) -> Result<Buffer> {
        Buffer::holding(ctx, name, data, vk::BufferUsageFlags::empty())
    }

    /// A device-local storage buffer holding `data` that can also hold the workgroup counts
    /// of an indirect dispatch ([`super::ComputePipeline::dispatch_indirect`]).
    pub fn indirect<T: Pod>(ctx: &Arc<Context>, name: &str, data: &[T]) -> Result<Buffer> {
        Buffer::holding(ctx, name, data, vk::BufferUsageFlags::INDIRECT_BUFFER)
    }

    /// A device-local buffer holding `data` that kernels can read as RGBA32UI texels
    /// (`uniform usamplerBuffer`, one texel per 16 bytes) besides as a storage buffer.
    /// lavapipe (Mesa 22.3) loads each word of a storage buffer with a loop over the SIMD
    /// lanes and a bounds-check branch per lane, and a texel with one 16-byte load per lane:
    /// one more BVH node load (then 64 bytes) per traversal step made `bench-rays` 1.6× slower, so the
    /// hot read-only data (BVH, light tree) is read as texels. `T` must be a multiple of 16
    /// bytes.
    pub fn texels<T: Pod>(ctx: &Arc<Context>, name: &str, data: &[T]) -> Result<Buffer> {
        assert!(
            std::mem::size_of::<T>().is_multiple_of(16),
            "texel buffers hold whole 16-byte texels"
        );
        let texels = check_texels(ctx, name, std::mem::size_of_val(data) as u64 / 16)?;
        let buf = Buffer::holding(ctx, name, data, vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER)?;
        buf.with_view(vk::Format::R32G32B32A32_UINT, texels)
    }

    /// A device-local buffer holding `data` that kernels can read as R32UI texels (one word
    /// each) besides as a storage buffer: the per-lane gather of [`Buffer::texels`] for
    /// arrays of words (cuts, region index).
    pub fn words(ctx: &Arc<Context>, name: &str, data: &[u32]) -> Result<Buffer> {
        let buf = Buffer::words_unfilled(ctx, name, data.len())?;
        buf.write(bytemuck::cast_slice(data))?;
        Ok(buf)
    }

    /// A device-local buffer of `len` words readable as R32UI texels, as [`Buffer::words`],
    /// with its contents not set: for the caller to fill before any kernel reads it (one
    /// upload among others, [`super::Transfers`]).
    pub fn words_unfilled(ctx: &Arc<Context>, name: &str, len: usize) -> Result<Buffer> {
        let texels = check_texels(ctx, name, len as u64)?;
        Buffer::device_local(
            ctx,
            name,
            4 * len as u64,
            vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER,
        )?
        .with_view(vk::Format::R32_UINT, texels)
    }

    /// A zero-filled device-local buffer of `size` bytes (a multiple of 16) that kernels can
    /// read as texels, as [`Buffer::texels`].
    pub fn zeroed_texels(ctx: &Arc<Context>, name: &str, size: u64) -> Result<Buffer> {
        Buffer::zeroed_texels_with(ctx, name, size, vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER)
    }

    /// A zero-filled device-local buffer of `size` bytes (a multiple of 16) that kernels read
    /// as RGBA32UI texels and write as a storage texel buffer (`uimageBuffer`) through the
    /// same view: scratch data one dispatch writes and the next reads (a wavefront's
    /// queues), read with the vector loads of [`Buffer::texels`].
    pub fn scratch_texels(ctx: &Arc<Context>, name: &str, size: u64) -> Result<Buffer> {
        Buffer::zeroed_texels_with(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER | vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER,
        )
    }

    /// A zero-filled buffer of `size` bytes (a multiple of 16) with `usage` besides storage,
    /// viewed as RGBA32UI texels.
    fn zeroed_texels_with(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> Result<Buffer> {
        assert!(
            size.is_multiple_of(16),
            "texel buffers hold whole 16-byte texels"
        );
        let texels = check_texels(ctx, name, size / 16)?;
        Buffer::zeroed_with(ctx, name, size, usage)?
            .with_view(vk::Format::R32G32B32A32_UINT, texels)
    }

    /// A zero-filled device-local storage buffer of `size` bytes that indirect dispatches
    /// can read their workgroup counts from.
    pub fn zeroed_indirect(ctx: &Arc<Context>, name: &str, size: u64) -> Result<Buffer> {
        Buffer::zeroed_with(ctx, name, size, vk::BufferUsageFlags::INDIRECT_BUFFER)
    }

    /// Records a write of `bytes` (at most 65536, a multiple of 4) at `offset` into a
    /// command buffer: ordered with the dispatches around it by [`Context::barrier`].
    pub fn record_write(&self, cmd: vk::CommandBuffer, offset: u64, bytes: &[u8]) {
        unsafe {
            self.ctx
                .device
                .cmd_update_buffer(cmd, self.raw, offset, bytes)
        };
    }

    /// The buffer with a view of its first `texels` texels of `format` (RGBA32UI, R32UI).
    fn with_view(mut self, format: vk::Format, texels: u64) -> Result<Buffer> {
        let bytes = if format == vk::Format::R32_UINT {
            4
        } else {
            16
        };
        let info = vk::BufferViewCreateInfo::default()
            .buffer(self.raw)
            .format(format)
            .offset(0)
            .range(texels * bytes);
        self.view = Some(unsafe { self.ctx.device.create_buffer_view(&info, None) }?);
        Ok(self)
    }

    /// A device-local storage buffer holding `data`, with `extra` usage.
    fn holding<T: Pod>(
        ctx: &Arc<Context>,
        name: &str,
        data: &[T],
        extra: vk::BufferUsageFlags,
    ) -> Result<Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buf = Buffer::device_local(ctx, name, bytes.len() as u64, extra)?;
        buf.write(bytes)?;
        Ok(buf)
    }

    /// A device-local storage buffer of `size` bytes, with `extra` usage, its contents not
    /// set.
    fn device_local(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        extra: vk::BufferUsageFlags,
    ) -> Result<Buffer> {
        Buffer::new(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC
                | extra,
            MemoryLocation::GpuOnly,
        )
    }

    /// A zero-filled device-local storage buffer of `size` bytes.
    pub fn zeroed(ctx: &Arc<Context>, name: &str, size: u64) -> Result<Buffer> {
        Buffer::zeroed_with(ctx, name, size, vk::BufferUsageFlags::empty())
    }

    /// A zero-filled device-local storage buffer of `size` bytes, with `extra` usage.
    fn zeroed_with(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        extra: vk::BufferUsageFlags,
    ) -> Result<Buffer> {
        let buf = Buffer::device_local(ctx, name, size, extra)?;
        buf.clear()?;
        Ok(buf)
    }

    /// Fills the buffer with zeros.
    pub fn clear(&self) -> Result<()> {
        let mut up = Transfers::new();
        up.clear(self);
        up.submit(&self.ctx, |_| {})
    }

    /// Copies `bytes` to the start of the buffer through a staging buffer.
    pub fn write(&self, bytes: &[u8]) -> Result<()> {
        self.write_at(0, bytes)
    }

    /// Copies the first `min(size)` bytes of `src` into this buffer (GPU to GPU).
    pub fn copy_from(&self, src: &Buffer) -> Result<()> {
        let region = [vk::BufferCopy::default().size(self.size.min(src.size))];
        self.ctx.submit(|cmd| unsafe {
            // Earlier submissions' writes (kernels, the clear of this buffer) first.
            self.ctx.barrier(cmd);
            self.ctx
                .device
                .cmd_copy_buffer(cmd, src.raw, self.raw, &region)
        })
    }

    /// Copies `bytes` into the buffer at byte `offset` through a staging buffer.
    pub fn write_at(&self, offset: u64, bytes: &[u8]) -> Result<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        let mut up = Transfers::new();
        up.write(self, offset, bytes);
        up.submit(&self.ctx, |_| {})
    }

    /// Reads the first `count` `T`s back.
    pub fn read_first<T: Pod>(&self, count: usize) -> Result<Vec<T>> {
        let bytes = (count * std::mem::size_of::<T>()) as u64;
        assert!(bytes <= self.size, "read past the end of a buffer");
        self.read_bytes(bytes.max(4), count)
    }

    /// Reads the whole buffer back as `T`s.
    pub fn read<T: Pod>(&self) -> Result<Vec<T>> {
        self.read_bytes(self.size, self.size as usize / std::mem::size_of::<T>())
    }

    /// Copies the first `bytes` bytes to a host-visible staging buffer and returns the
    /// first `count` `T`s of them.
    fn read_bytes<T: Pod>(&self, bytes: u64, count: usize) -> Result<Vec<T>> {
        let got = read_many(&self.ctx, &[(self, bytes)])?;
        Ok(pod_vec(&got[0][..count * std::mem::size_of::<T>()]))
    }

    pub(super) fn mapped(&self) -> Result<&[u8]> {
        let a = self.allocation.as_ref().expect("live buffer");
        a.mapped_slice()
            .context("buffer is not host-visible (internal error)")
    }

    pub(super) fn mapped_mut(&mut self) -> Result<&mut [u8]> {
        let a = self.allocation.as_mut().expect("live buffer");
        a.mapped_slice_mut()
            .context("buffer is not host-visible (internal error)")
    }
}

/// `texels` (at least 1: a buffer is never empty) if the device's texel buffers hold them.
fn check_texels(ctx: &Context, name: &str, texels: u64) -> Result<u64> {
    let max = ctx.properties.limits.max_texel_buffer_elements as u64;
    if texels > max {
        anyhow::bail!(
            "buffer '{name}' needs {texels} texels but this device allows texel buffers of at most {max}; use a smaller scene"
        );
    }
    Ok(texels.max(1))
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(view) = self.view.take() {
            unsafe { self.ctx.device.destroy_buffer_view(view, None) };
        }
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator.lock().map(|mut al| al.free(a));
        }
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
    }
}
