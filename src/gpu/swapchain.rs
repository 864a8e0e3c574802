//! A swapchain on the context's window surface, and presenting a buffer of 8-bit pixels
//! into it: acquire (host-waited on a fence), one submission that copies the buffer into the
//! image with the layout changes around it, present. Recreated on resize and when the
//! surface reports it out of date. Knows no renderer.

use std::sync::Arc;

use anyhow::{anyhow, bail, Result};
use ash::vk;

use super::{Buffer, Context};

pub struct Swapchain {
    ctx: Arc<Context>,
    loader: ash::khr::swapchain::Device,
    handle: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    pub extent: vk::Extent2D,
    pub format: vk::Format,
    fence: vk::Fence,
}

/// What presenting did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Presented {
    Shown,
    /// The surface changed (resize): recreate the swapchain and draw again.
    OutOfDate,
}

impl Swapchain {
    /// A swapchain of `width`×`height` (clamped to what the surface allows) on the context's
    /// surface, replacing `old` if given.
    pub fn new(
        ctx: &Arc<Context>,
        width: u32,
        height: u32,
        old: Option<Swapchain>,
    ) -> Result<Swapchain> {
        let surface = ctx
            .surface
            .as_ref()
            .ok_or_else(|| anyhow!("this Vulkan context has no window surface"))?;
        let caps = unsafe {
            surface
                .loader
                .get_physical_device_surface_capabilities(ctx.physical, surface.handle)
        }?;
        if !caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::TRANSFER_DST)
        {
            bail!("the window surface cannot be copied into (no TRANSFER_DST usage); this device cannot show the preview");
        }
        let formats = unsafe {
            surface
                .loader
                .get_physical_device_surface_formats(ctx.physical, surface.handle)
        }?;
        // 8-bit BGRA or RGBA; the pixels written are already sRGB-encoded, so the UNORM
        // format shows them as they are (a copy never converts).
        let chosen = formats
            .iter()
            .find(|f| {
                matches!(
                    f.format,
                    vk::Format::B8G8R8A8_UNORM | vk::Format::R8G8B8A8_UNORM
                ) && f.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR
            })
            .or_else(|| {
                formats.iter().find(|f| {
                    matches!(
                        f.format,
                        vk::Format::B8G8R8A8_SRGB | vk::Format::R8G8B8A8_SRGB
                    )
                })
            })
            .copied()
            .ok_or_else(|| {
                anyhow!("the window surface offers no 8-bit RGBA/BGRA format ({formats:?})")
            })?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: width.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: height.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let loader = ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device);
        let old_handle = old.as_ref().map_or(vk::SwapchainKHR::null(), |o| o.handle);
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(surface.handle)
            .min_image_count(count)
            .image_format(chosen.format)
            .image_color_space(chosen.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(old_handle);
        let handle = unsafe { loader.create_swapchain(&info, None) }?;
        drop(old);
        let images = unsafe { loader.get_swapchain_images(handle) }?;
        let fence = unsafe {
            ctx.device
                .create_fence(&vk::FenceCreateInfo::default(), None)
        }?;
        Ok(Swapchain {
            ctx: ctx.clone(),
            loader,
            handle,
            images,
            extent,
            format: chosen.format,
            fence,
        })
    }

    /// Whether pixels are to be written blue first (BGRA formats).
    pub fn bgra(&self) -> bool {
        matches!(
            self.format,
            vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB
        )
    }

    /// Shows `pixels` (extent.width × extent.height packed 8-bit pixels in the swapchain's
    /// channel order, row by row from the top): acquire, copy, present.
    pub fn present(&self, pixels: &Buffer) -> Result<Presented> {
        let d = &self.ctx.device;
        let acquired = unsafe {
            self.loader
                .acquire_next_image(self.handle, u64::MAX, vk::Semaphore::null(), self.fence)
        };
        let index = match acquired {
            Ok((i, _suboptimal)) => i,
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => return Ok(Presented::OutOfDate),
            Err(e) => bail!("cannot acquire a window image: {e}"),
        };
        unsafe {
            d.wait_for_fences(&[self.fence], true, u64::MAX)?;
            d.reset_fences(&[self.fence])?;
        }
        let image = self.images[index as usize];
        let extent = self.extent;
        self.ctx.submit(|cmd| unsafe {
            let to_dst = [layout_change(
                image,
                (
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                ),
                (vk::AccessFlags::empty(), vk::AccessFlags::TRANSFER_WRITE),
            )];
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE | vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                    .dst_access_mask(vk::AccessFlags::TRANSFER_READ)],
                &[],
                &to_dst,
            );
            let region = [vk::BufferImageCopy::default()
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D {
                    width: extent.width,
                    height: extent.height,
                    depth: 1,
                })];
            d.cmd_copy_buffer_to_image(
                cmd,
                pixels.raw,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &region,
            );
            let to_present = [layout_change(
                image,
                (
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::PRESENT_SRC_KHR,
                ),
                (vk::AccessFlags::TRANSFER_WRITE, vk::AccessFlags::empty()),
            )];
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_present,
            );
        })?;
        // The copy has completed (submit waits): nothing to wait on before presenting.
        let swapchains = [self.handle];
        let indices = [index];
        let info = vk::PresentInfoKHR::default()
            .swapchains(&swapchains)
            .image_indices(&indices);
        match unsafe { self.loader.queue_present(self.ctx.queue, &info) } {
            Ok(false) => Ok(Presented::Shown),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Presented::OutOfDate),
            Err(e) => bail!("cannot present to the window: {e}"),
        }
    }
}

/// A layout change of a whole colour image, (old, new) layouts and (src, dst) accesses.
fn layout_change(
    image: vk::Image,
    (old, new): (vk::ImageLayout, vk::ImageLayout),
    (src, dst): (vk::AccessFlags, vk::AccessFlags),
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .src_access_mask(src)
        .dst_access_mask(dst)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(
            vk::ImageSubresourceRange::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .level_count(1)
                .layer_count(1),
        )
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        unsafe {
            let _ = self.ctx.device.device_wait_idle();
            self.ctx.device.destroy_fence(self.fence, None);
            self.loader.destroy_swapchain(self.handle, None);
        }
    }
}
