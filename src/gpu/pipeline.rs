//! A compute pipeline whose descriptor sets hold storage buffers (set k: bindings 0..N_k),
//! with push constants and u32 specialization constants (constant_id = index). Each set is
//! bound on its own, so a caller rebinds only the set whose buffers changed.

use std::sync::Arc;

use anyhow::{Context as _, Result};
use ash::vk;

use super::buffer::Buffer;
use super::context::Context;

pub struct ComputePipeline {
    ctx: Arc<Context>,
    module: vk::ShaderModule,
    set_layouts: Vec<vk::DescriptorSetLayout>,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    pool: vk::DescriptorPool,
    sets: Vec<vk::DescriptorSet>,
    /// Bindings of each set.
    bindings: Vec<u32>,
}

impl ComputePipeline {
    /// One set of `bindings` storage buffers.
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

    /// Set k holds `bindings[k]` storage buffers.
    pub fn with_sets(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        bindings: &[u32],
        push_size: u32,
        specialization: &[u32],
    ) -> Result<ComputePipeline> {
        let d = &ctx.device;
        let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
            .with_context(|| format!("kernel '{name}' is not valid SPIR-V"))?;
        unsafe {
            let module =
                d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&code), None)?;
            let mut set_layouts = Vec::new();
            for &n in bindings {
                let binding_info: Vec<_> = (0..n)
                    .map(|b| {
                        vk::DescriptorSetLayoutBinding::default()
                            .binding(b)
                            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                            .descriptor_count(1)
                            .stage_flags(vk::ShaderStageFlags::COMPUTE)
                    })
                    .collect();
                set_layouts.push(d.create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&binding_info),
                    None,
                )?);
            }
            let push = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .size(push_size)];
            let layout = d.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default()
                    .set_layouts(&set_layouts)
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
                .module(module)
                .name(c"main")
                .specialization_info(&spec);
            let info = [vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(layout)];
            let pipeline = d
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
                .map_err(|(_, e)| e)
                .with_context(|| format!("cannot create the '{name}' compute pipeline"))?[0];
            let sizes = [vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(bindings.iter().sum::<u32>().max(1))];
            let pool = d.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(bindings.len() as u32)
                    .pool_sizes(&sizes),
                None,
            )?;
            let sets = d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&set_layouts),
            )?;
            let p = ComputePipeline {
                ctx: ctx.clone(),
                module,
                set_layouts,
                layout,
                pipeline,
                pool,
                sets,
                bindings: bindings.to_vec(),
            };
            ctx.check_validation()?;
            Ok(p)
        }
    }

    /// Points bindings 0..N of set 0 at `buffers` (in order).
    pub fn bind(&self, buffers: &[&Buffer]) -> Result<()> {
        self.bind_set(0, buffers)
    }

    /// Points bindings 0..N of `set` at `buffers` (in order).
    pub fn bind_set(&self, set: usize, buffers: &[&Buffer]) -> Result<()> {
        assert_eq!(
            buffers.len() as u32,
            self.bindings[set],
            "one buffer per binding"
        );
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|b| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.raw)
                    .offset(0)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let writes: Vec<_> = infos
            .iter()
            .enumerate()
            .map(|(i, info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(self.sets[set])
                    .dst_binding(i as u32)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(info)
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
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &self.sets,
                &[],
            );
            if !push.is_empty() {
                d.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
            }
        }
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        unsafe {
            d.destroy_descriptor_pool(self.pool, None);
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            for l in &self.set_layouts {
                d.destroy_descriptor_set_layout(*l, None);
            }
            d.destroy_shader_module(self.module, None);
        }
    }
}
