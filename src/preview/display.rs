//! The preview's display pass: `shaders/preview.comp` turns the session's film into the
//! window's 8-bit pixels, which the swapchain presents.

use std::sync::Arc;

use anyhow::Result;

use crate::gpu::layout::PreviewParams;
use crate::gpu::swapchain::{Presented, Swapchain};
use crate::gpu::{kernels, Buffer, ComputePipeline, Context};
use crate::render::Session;

pub struct Display {
    ctx: Arc<Context>,
    pipeline: ComputePipeline,
    pixels: Buffer,
    /// Always Some between calls (taken while it is replaced).
    swapchain: Option<Swapchain>,
}

impl Display {
    pub fn new(ctx: &Arc<Context>, width: u32, height: u32) -> Result<Display> {
        let swapchain = Swapchain::new(ctx, width, height, None)?;
        let pipeline = ComputePipeline::new(
            ctx,
            "preview",
            kernels::PREVIEW,
            2,
            std::mem::size_of::<PreviewParams>() as u32,
            &[],
        )?;
        let pixels = Self::pixel_buffer(ctx, &swapchain)?;
        Ok(Display {
            ctx: ctx.clone(),
            pipeline,
            pixels,
            swapchain: Some(swapchain),
        })
    }

    fn pixel_buffer(ctx: &Arc<Context>, s: &Swapchain) -> Result<Buffer> {
        Buffer::zeroed(
            ctx,
            "preview pixels",
            4 * s.extent.width as u64 * s.extent.height as u64,
        )
    }

    fn swapchain(&self) -> &Swapchain {
        self.swapchain.as_ref().expect("a swapchain between calls")
    }

    /// The window's size as the swapchain has it.
    pub fn extent(&self) -> (u32, u32) {
        let e = self.swapchain().extent;
        (e.width, e.height)
    }

    /// A new swapchain for a window of `width`×`height`.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        if width == 0 || height == 0 {
            // Minimised: keep the swapchain until the window has a size again.
            return Ok(());
        }
        // The old swapchain is handed over (oldSwapchain) and destroyed once the new one
        // exists.
        let old = self.swapchain.take();
        self.swapchain = Some(Swapchain::new(&self.ctx, width.max(1), height.max(1), old)?);
        self.pixels = Self::pixel_buffer(&self.ctx, self.swapchain())?;
        Ok(())
    }

    /// Shows `pixels` (the window's size, packed as the swapchain wants: see [`Self::bgra`]).
    pub fn show_pixels(&mut self, pixels: &[u32]) -> Result<Presented> {
        self.pixels.write(bytemuck::cast_slice(pixels))?;
        self.swapchain().present(&self.pixels)
    }

    /// Whether packed pixels are blue first.
    pub fn bgra(&self) -> bool {
        self.swapchain().bgra()
    }

    /// Shows the session's film (exposure: a linear factor; view 0 image, 1 relative error,
    /// 2 zero-light-sample share).
    pub fn show(&mut self, session: &Session, exposure: f32, view: u32) -> Result<Presented> {
        let (accum, fw, fh) = session.film();
        let e = self.swapchain().extent;
        let spp = session.spp();
        let params = PreviewParams {
            film_width: fw,
            film_height: fh,
            out_width: e.width,
            out_height: e.height,
            mean_scale: session.radiance_scale() * exposure / spp.max(1) as f32,
            spp: spp as f32,
            view,
            bgra: self.swapchain().bgra() as u32,
        };
        self.pipeline.bind(&[accum, &self.pixels])?;
        let groups = [e.width.div_ceil(8), e.height.div_ceil(8), 1];
        self.ctx.submit(|cmd| {
            self.pipeline
                .dispatch(cmd, bytemuck::bytes_of(&params), groups)
        })?;
        self.swapchain().present(&self.pixels)
    }
}
