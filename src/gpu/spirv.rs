//! What kind of descriptor each (set, binding) of a compute kernel is, read from its SPIR-V,
//! so a pipeline's layout follows the kernel: storage buffers, and uniform texel buffers
//! (`uniform usamplerBuffer`), which kernels read hot data through because lavapipe loads a
//! storage-buffer word with a per-lane loop and a branch, and a texel of four words with one
//! vector load per lane (src/gpu/buffer.rs `Buffer::texels`).

use std::collections::HashMap;

use anyhow::{bail, Result};
use ash::vk;

const OP_NAME: u32 = 5;
const OP_TYPE_IMAGE: u32 = 25;
const OP_TYPE_SAMPLED_IMAGE: u32 = 27;
const OP_TYPE_POINTER: u32 = 32;
const OP_VARIABLE: u32 = 59;
const OP_DECORATE: u32 = 71;
const DECORATION_BINDING: u32 = 33;
const DECORATION_SPEC_ID: u32 = 1;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const DIM_BUFFER: u32 = 5;

/// One binding of a kernel: its set, number, descriptor type and variable name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Binding {
    pub set: u32,
    pub binding: u32,
    pub kind: vk::DescriptorType,
    pub name: String,
}

/// The bindings of a module, sorted by (set, binding). Anything but storage buffers and
/// uniform or storage texel buffers (`uimageBuffer`, which the wavefront's path queues are
/// written through) is refused: the device layer makes no other descriptors.
pub fn bindings(spirv: &[u32]) -> Result<Vec<Binding>> {
    let mut names: HashMap<u32, String> = HashMap::new();
    let mut set: HashMap<u32, u32> = HashMap::new();
    let mut binding: HashMap<u32, u32> = HashMap::new();
    let mut pointee: HashMap<u32, u32> = HashMap::new();
    // Image types by id: (dim, sampled); sampled images by id: their image type.
    let mut images: HashMap<u32, (u32, u32)> = HashMap::new();
    let mut sampled: HashMap<u32, u32> = HashMap::new();
    let mut vars = Vec::new();
    for ins in instructions(spirv)? {
        match (ins[0] & 0xffff, ins.len()) {
            (OP_NAME, 3..) => {
                let bytes: Vec<u8> = ins[2..].iter().flat_map(|w| w.to_le_bytes()).collect();
                let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                names.insert(ins[1], String::from_utf8_lossy(&bytes[..end]).into_owned());
            }
            (OP_DECORATE, 4..) if ins[2] == DECORATION_DESCRIPTOR_SET => {
                set.insert(ins[1], ins[3]);
            }
            (OP_DECORATE, 4..) if ins[2] == DECORATION_BINDING => {
                binding.insert(ins[1], ins[3]);
            }
            // OpTypeImage: result, sampled type, dim, depth, arrayed, ms, sampled, format.
            (OP_TYPE_IMAGE, 9..) => {
                images.insert(ins[1], (ins[3], ins[7]));
            }
            (OP_TYPE_SAMPLED_IMAGE, 3..) => {
                sampled.insert(ins[1], ins[2]);
            }
            (OP_TYPE_POINTER, 4..) => {
                pointee.insert(ins[1], ins[3]);
            }
            (OP_VARIABLE, 4..) => vars.push((ins[2], ins[1])),
            _ => {}
        }
    }
    let mut out = Vec::new();
    for (var, ptr) in vars {
        let Some(&b) = binding.get(&var) else {
            continue;
        };
        let ty = pointee.get(&ptr).copied().unwrap_or(0);
        let image = sampled.get(&ty).copied().unwrap_or(ty);
        let kind = match images.get(&image) {
            None => vk::DescriptorType::STORAGE_BUFFER,
            Some(&(DIM_BUFFER, 1)) => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
            Some(&(DIM_BUFFER, 2)) => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
            Some(&(dim, s)) => bail!(
                "binding {b} is an image (dim {dim}, sampled {s}); only storage buffers and texel buffers are supported"
            ),
        };
        out.push(Binding {
            set: set.get(&var).copied().unwrap_or(0),
            binding: b,
            kind,
            name: names.get(&var).cloned().unwrap_or_default(),
        });
    }
    out.sort_by_key(|b| (b.set, b.binding));
    Ok(out)
}

/// The specialization-constant ids a module declares (`layout(constant_id = k)`), sorted:
/// the pipeline checks that the host gives each of them a value (src/gpu/pipeline.rs), so a
/// constant added to a kernel but not to its caller is an error, not its default in silence.
pub fn spec_ids(spirv: &[u32]) -> Result<Vec<u32>> {
    let mut ids: Vec<u32> = instructions(spirv)?
        .into_iter()
        .filter(|ins| ins[0] & 0xffff == OP_DECORATE && ins.len() >= 4)
        .filter(|ins| ins[2] == DECORATION_SPEC_ID)
        .map(|ins| ins[3])
        .collect();
    ids.sort_unstable();
    Ok(ids)
}

/// The instructions of a module after its five-word header, each as its words (the opcode
/// and word count first); an instruction that overruns the module is an error.
fn instructions(spirv: &[u32]) -> Result<Vec<&[u32]>> {
    if spirv.len() < 5 || spirv[0] != 0x0723_0203 {
        bail!("not a SPIR-V module");
    }
    let mut out = Vec::new();
    let mut i = 5;
    while i < spirv.len() {
        let count = (spirv[i] >> 16) as usize;
        if count == 0 || i + count > spirv.len() {
            bail!("SPIR-V instruction at word {i} overruns the module");
        }
        out.push(&spirv[i..i + count]);
        i += count;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(spv: &[u8]) -> Vec<u32> {
        ash::util::read_spv(&mut std::io::Cursor::new(spv)).unwrap()
    }

    /// Fails if texel buffers were taken for storage buffers (checked by that mutation).
    #[test]
    fn texel_and_storage_bindings_are_told_apart() {
        let b = bindings(&words(crate::gpu::kernels::TEXELS)).unwrap();
        let kind = |n: u32| {
            b.iter()
                .find(|x| x.set == 0 && x.binding == n)
                .map(|x| x.kind)
        };
        assert_eq!(kind(0), Some(vk::DescriptorType::UNIFORM_TEXEL_BUFFER));
        assert_eq!(b[0].name, "bvh_node_texels");
        assert_eq!(kind(6), Some(vk::DescriptorType::STORAGE_BUFFER));
        let texel = |k: &[u8]| {
            bindings(&words(k))
                .unwrap()
                .iter()
                .filter(|x| x.kind == vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                .count()
        };
        assert_eq!(texel(crate::gpu::kernels::TEXELS), 9);
        assert_eq!(texel(crate::gpu::kernels::FOLD), 3);
    }

    /// Fails if a storage texel buffer (`uimageBuffer`, the path queues' writes) were taken
    /// for a uniform texel buffer or refused.
    #[test]
    fn storage_texel_buffers_are_recognised() {
        let b = bindings(&words(crate::gpu::kernels::render(5, false))).unwrap();
        let kind = |name: &str| b.iter().find(|x| x.name == name).map(|x| x.kind);
        assert_eq!(
            kind("path_image"),
            Some(vk::DescriptorType::STORAGE_TEXEL_BUFFER)
        );
        assert_eq!(
            kind("path_texels"),
            Some(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
        );
    }

    /// The render kernel's constants, SAMPLER (0) … STRATIFY (9), less SAMPLER and
    /// DIRECT_ONLY (5), which build.rs fixes per variant; the test kernel light_sample.comp
    /// leaves 2 out. Fails if the decoration were read from another word.
    #[test]
    fn specialization_ids_are_read() {
        for render in crate::gpu::kernels::render_variants() {
            let ids = spec_ids(&words(render)).unwrap();
            assert_eq!(ids, [1, 2, 3, 4, 6, 7, 8, 9]);
        }
        let sampler = spec_ids(&words(crate::gpu::kernels::LIGHT_SAMPLE)).unwrap();
        assert_eq!(sampler, [0, 1, 3]);
        assert!(spec_ids(&words(crate::gpu::kernels::FOLD))
            .unwrap()
            .is_empty());
    }

    #[test]
    fn a_damaged_module_is_an_error() {
        assert!(bindings(&[1, 2, 3]).is_err());
        assert!(spec_ids(&[1, 2, 3]).is_err());
        let mut w = words(crate::gpu::kernels::FOLD);
        w.truncate(w.len() - 1);
        w.push(0x00ff_0000); // an instruction that claims 255 words
        assert!(bindings(&w).is_err());
    }
}
