//! A compute pipeline whose descriptor sets hold buffers (set k: bindings 0..N_k), each a
//! storage buffer or a uniform or storage texel buffer as the kernel declares it (src/gpu/spirv.rs),
//! with push constants and u32 specialization constants (constant_id = index). Each set is
//! bound on its own, so a caller rebinds only the set whose buffers changed.

use std::sync::Arc;

use anyhow::{bail, Context as _, Result};
use ash::vk;

use super::buffer::Buffer;
use super::context::Context;
use super::spirv;

pub struct ComputePipeline {
    ctx: Arc<Context>,
    compiled: Arc<Compiled>,
    pool: vk::DescriptorPool,
    sets: Vec<vk::DescriptorSet>,
}

/// A kernel compiled with its specialization: what does not depend on the buffers bound.
/// Kept by the context ([`CompiledCache`]) and destroyed with it: lavapipe spent ~0.2 s of
/// CPU creating a session's pipelines (its NIR passes), which `animate` paid every frame
/// (an audit, 2026-12-07: 2001 frames of 8×6 took 9 min 18 s, 6.8 s of it rendering).
pub struct Compiled {
    module: vk::ShaderModule,
    set_layouts: Vec<vk::DescriptorSetLayout>,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    /// The descriptor type of each binding of each set.
    kinds: Vec<Vec<vk::DescriptorType>>,
}

/// Compiled kernels by (name, SPIR-V checksum, bindings, push size, specialization).
pub type CompiledCache =
    std::collections::HashMap<(String, u64, Vec<u32>, u32, Vec<u32>), Arc<Compiled>>;

impl Compiled {
    /// # Safety
    /// Only when no pipeline uses it any more: the context's drop.
    pub(super) unsafe fn destroy(&self, d: &ash::Device) {
        d.destroy_pipeline(self.pipeline, None);
        d.destroy_pipeline_layout(self.layout, None);
        for l in &self.set_layouts {
            d.destroy_descriptor_set_layout(*l, None);
        }
        d.destroy_shader_module(self.module, None);
    }
}

impl ComputePipeline {
    /// One set of `bindings` buffers.
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        bindings: u32,
        push_size: u32,
        specialization: &[u32],
    ) -> Result<ComputePipeline> {
        Self::with_sets(ctx, name, spirv, &[bindings], push_size, specialization)
    }

    /// Set k holds `bindings[k]` buffers (bindings 0..`bindings[k]`). The kernel is compiled
    /// once per context for each specialization ([`Compiled`]); the descriptor sets are this
    /// pipeline's own.
    pub fn with_sets(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        bindings: &[u32],
        push_size: u32,
        specialization: &[u32],
    ) -> Result<ComputePipeline> {
        let key = (
            name.to_string(),
            crate::fnv::fnv1a(spirv),
            bindings.to_vec(),
            push_size,
            specialization.to_vec(),
        );
        let cache = || {
            ctx.compiled
                .lock()
                .map_err(|_| anyhow::anyhow!("the kernel cache was poisoned by a panic"))
        };
        let cached = cache()?.get(&key).cloned();
        let compiled = match cached {
            Some(c) => c,
            None => {
                let c = Arc::new(Self::compile(
                    ctx,
                    name,
                    spirv,
                    bindings,
                    push_size,
                    specialization,
                )?);
                // Another thread may have compiled the same kernel meanwhile: one is kept,
                // the other destroyed (it was left undestroyed: a review, 2026-12-07).
                let kept = cache()?.entry(key).or_insert_with(|| c.clone()).clone();
                if Arc::ptr_eq(&kept, &c) {
                    ctx.compiles
                        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                } else {
                    // SAFETY: `c` was made here and nothing else holds it.
                    unsafe { c.destroy(&ctx.device) };
                }
                kept
            }
        };
        let d = &ctx.device;
        let kinds = &compiled.kinds;
        unsafe {
            let count = |kind| kinds.iter().flatten().filter(|&&k| k == kind).count() as u32;
            let sizes = [
                vk::DescriptorPoolSize::default()
                    .ty(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(count(vk::DescriptorType::STORAGE_BUFFER).max(1)),
                vk::DescriptorPoolSize::default()
                    .ty(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                    .descriptor_count(count(vk::DescriptorType::UNIFORM_TEXEL_BUFFER).max(1)),
                vk::DescriptorPoolSize::default()
                    .ty(vk::DescriptorType::STORAGE_TEXEL_BUFFER)
                    .descriptor_count(count(vk::DescriptorType::STORAGE_TEXEL_BUFFER).max(1)),
            ];
            let pool = d.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(bindings.len() as u32)
                    .pool_sizes(&sizes),
                None,
            )?;
            let sets = match d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&compiled.set_layouts),
            ) {
                Ok(s) => s,
                Err(e) => {
                    d.destroy_descriptor_pool(pool, None);
                    return Err(e.into());
                }
            };
            let p = ComputePipeline {
                ctx: ctx.clone(),
                compiled,
                pool,
                sets,
            };
            ctx.check_validation()?;
            Ok(p)
        }
    }

    /// The kernel `name` compiled with `specialization`.
    fn compile(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        bindings: &[u32],
        push_size: u32,
        specialization: &[u32],
    ) -> Result<Compiled> {
        let d = &ctx.device;
        let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
            .with_context(|| format!("kernel '{name}' is not valid SPIR-V"))?;
        let declared = spirv::bindings(&code).with_context(|| format!("kernel '{name}'"))?;
        // Every constant the kernel declares gets a value here (one it does not declare, as
        // light_sample.comp skips id 2, is ignored by Vulkan).
        let spec_ids = spirv::spec_ids(&code).with_context(|| format!("kernel '{name}'"))?;
        if let Some(&id) = spec_ids
            .iter()
            .find(|&&id| id as usize >= specialization.len())
        {
            bail!(
                "kernel '{name}' declares specialization constant {id} but is given {} values: the host and the kernel disagree",
                specialization.len()
            );
        }
        let kinds: Vec<Vec<vk::DescriptorType>> = (0..bindings.len() as u32)
            .map(|set| {
                (0..bindings[set as usize])
                    .map(|b| {
                        declared
                            .iter()
                            .find(|d| d.set == set && d.binding == b)
                            .map_or(vk::DescriptorType::STORAGE_BUFFER, |d| d.kind)
                    })
                    .collect()
            })
            .collect();
        // What a failure part way made is destroyed again: left, it was a leak that the
        // validation layer reports at the context's end (a review, 2026-12-07).
        let mut made = Compiled {
            module: vk::ShaderModule::null(),
            set_layouts: Vec::new(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            kinds: kinds.clone(),
        };
        let built = unsafe {
            (|| -> Result<()> {
                made.module = d.create_shader_module(
                    &vk::ShaderModuleCreateInfo::default().code(&code),
                    None,
                )?;
                for set in &kinds {
                    let binding_info: Vec<_> = set
                        .iter()
                        .enumerate()
                        .map(|(b, &kind)| {
                            vk::DescriptorSetLayoutBinding::default()
                                .binding(b as u32)
                                .descriptor_type(kind)
                                .descriptor_count(1)
                                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                        })
                        .collect();
                    made.set_layouts.push(d.create_descriptor_set_layout(
                        &vk::DescriptorSetLayoutCreateInfo::default().bindings(&binding_info),
                        None,
                    )?);
                }
                let push = [vk::PushConstantRange::default()
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
                    .size(push_size)];
                made.layout = d.create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default()
                        .set_layouts(&made.set_layouts)
                        .push_constant_ranges(if push_size > 0 { &push } else { &[] }),
                    None,
                )?;
                let entries: Vec<_> = (0..specialization.len() as u32)
                    .map(|i| {
                        vk::SpecializationMapEntry::default()
                            .constant_id(i)
                            .offset(4 * i)
                            .size(4)
                    })
                    .collect();
                let spec_data: &[u8] = bytemuck::cast_slice(specialization);
                let spec = vk::SpecializationInfo::default()
                    .map_entries(&entries)
                    .data(spec_data);
                let stage = vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::COMPUTE)
                    .module(made.module)
                    .name(c"main")
                    .specialization_info(&spec);
                let info = [vk::ComputePipelineCreateInfo::default()
                    .stage(stage)
                    .layout(made.layout)];
                made.pipeline = d
                    .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
                    .map_err(|(_, e)| e)
                    .with_context(|| format!("cannot create the '{name}' compute pipeline"))?[0];
                ctx.check_validation()
            })()
        };
        match built {
            Ok(()) => Ok(made),
            Err(e) => {
                unsafe { made.destroy(d) };
                Err(e)
            }
        }
    }

    /// Points bindings 0..N of set 0 at `buffers` (in order).
    pub fn bind(&self, buffers: &[&Buffer]) -> Result<()> {
        self.bind_set(0, buffers)
    }

    /// Points bindings 0..N of `set` at `buffers` (in order). A texel-buffer binding needs a
    /// buffer made by [`Buffer::texels`].
    pub fn bind_set(&self, set: usize, buffers: &[&Buffer]) -> Result<()> {
        let kinds = &self.compiled.kinds[set];
        assert_eq!(buffers.len(), kinds.len(), "one buffer per binding");
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|b| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.raw)
                    .offset(0)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let texel = |kind| {
            kind == vk::DescriptorType::UNIFORM_TEXEL_BUFFER
                || kind == vk::DescriptorType::STORAGE_TEXEL_BUFFER
        };
        let mut views: Vec<[vk::BufferView; 1]> = Vec::new();
        for (i, (b, &kind)) in buffers.iter().zip(kinds).enumerate() {
            if texel(kind) {
                let Some(view) = b.view else {
                    anyhow::bail!("binding {i} of set {set} reads texels, but its buffer was made without a texel view (internal error: use Buffer::texels)");
                };
                views.push([view]);
            }
        }
        let mut views = views.iter();
        let writes: Vec<_> = infos
            .iter()
            .zip(kinds)
            .enumerate()
            .map(|(i, (info, &kind))| {
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(self.sets[set])
                    .dst_binding(i as u32)
                    .descriptor_type(kind);
                if texel(kind) {
                    w.texel_buffer_view(views.next().expect("one view per texel binding"))
                } else {
                    w.buffer_info(info)
                }
            })
            .collect();
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
        self.ctx.check_validation()
    }

    /// Records push constants and a dispatch of `groups` workgroups.
    pub fn dispatch(&self, cmd: vk::CommandBuffer, push: &[u8], groups: [u32; 3]) {
        self.bind_for_dispatch(cmd, push);
        unsafe {
            self.ctx
                .device
                .cmd_dispatch(cmd, groups[0], groups[1], groups[2])
        };
    }

    /// Records push constants and a dispatch whose workgroup counts an earlier dispatch
    /// wrote: three u32 at byte `offset` of `args` (a buffer made by [`Buffer::indirect`]).
    pub fn dispatch_indirect(
        &self,
        cmd: vk::CommandBuffer,
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) {
        self.bind_for_dispatch(cmd, push);
        unsafe { self.ctx.device.cmd_dispatch_indirect(cmd, args.raw, offset) };
    }

    fn bind_for_dispatch(&self, cmd: vk::CommandBuffer, push: &[u8]) {
        let d = &self.ctx.device;
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.compiled.pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.compiled.layout,
                0,
                &self.sets,
                &[],
            );
            if !push.is_empty() {
                d.cmd_push_constants(
                    cmd,
                    self.compiled.layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    push,
                );
            }
        }
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // The compiled kernel stays with the context ([`CompiledCache`]).
        unsafe { d.destroy_descriptor_pool(self.pool, None) };
    }
}
