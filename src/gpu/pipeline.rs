//! A compute pipeline whose descriptor set is N storage buffers (bindings 0..N in set 0),
//! with push constants and u32 specialization constants (constant_id = index).

use std::sync::Arc;

use anyhow::{Context as _, Result};
use ash::vk;

use super::buffer::Buffer;
use super::context::Context;

pub struct ComputePipeline {
    ctx: Arc<Context>,
    module: vk::ShaderModule,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    bindings: u32,
}

impl ComputePipeline {
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        bindings: u32,
        push_size: u32,
        specialization: &[u32],
    ) -> Result<ComputePipeline> {
        let d = &ctx.device;
        let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
            .with_context(|| format!("kernel '{name}' is not valid SPIR-V"))?;
        unsafe {
            let module =
                d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&code), None)?;
            let binding_info: Vec<_> = (0..bindings)
                .map(|b| {
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(b)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .descriptor_count(1)
                        .stage_flags(vk::ShaderStageFlags::COMPUTE)
                })
                .collect();
            let set_layout = d.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&binding_info),
                None,
            )?;
            let push = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .size(push_size)];
            let set_layouts = [set_layout];
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
                .descriptor_count(bindings.max(1))];
            let pool = d.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(1)
                    .pool_sizes(&sizes),
                None,
            )?;
            let set = d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&set_layouts),
            )?[0];
            let p = ComputePipeline {
                ctx: ctx.clone(),
                module,
                set_layout,
                layout,
                pipeline,
                pool,
                set,
                bindings,
            };
            ctx.check_validation()?;
            Ok(p)
        }
    }

    /// Points bindings 0..N at `buffers` (in order).
    pub fn bind(&self, buffers: &[&Buffer]) -> Result<()> {
        assert_eq!(
            buffers.len() as u32,
            self.bindings,
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
                    .dst_set(self.set)
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
        let d = &self.ctx.device;
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[self.set],
                &[],
            );
            if !push.is_empty() {
                d.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
            }
            d.cmd_dispatch(cmd, groups[0], groups[1], groups[2]);
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
            d.destroy_descriptor_set_layout(self.set_layout, None);
            d.destroy_shader_module(self.module, None);
        }
    }
}
