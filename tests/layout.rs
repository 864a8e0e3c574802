//! Host/shader struct layouts: every `#[repr(C)]` struct in src/abi.rs must have the
//! same member names, offsets and size as its GLSL mirror in the compiled SPIR-V; and the
//! storage blocks of `render.comp` and `fold.comp` must sit at the bindings the session binds
//! them to (by name).
//!
//! A small SPIR-V reader, cross-checked by naga where naga can read a kernel: naga 30.0.2's
//! SPIR-V front end parses none of our kernels as compiled (`OpSpecConstantOp` in
//! render.comp and light_sample.comp, from the learned samplers' and the scene's flags and
//! the light-sample counts; `OpCopyLogical`, SPIR-V 1.4, in trace.comp, fold.comp and bsdf.comp), so
//! `naga_agrees_with_our_reader` compiles bsdf.comp and texels.comp (without its texel
//! buffers) for SPIR-V 1.0 and compares; trace.comp and fold.comp read texel buffers, which
//! naga refuses.

mod common;

use std::collections::HashMap;
use std::mem::{offset_of, size_of};

use lightlearn::gpu::kernels;
use lightlearn::gpu::layout::*;
use lightlearn::gpu::{Buffer, ComputePipeline};
use lightlearn::rng::SplitMix64;

/// What the SPIR-V says about one struct type: member (name, offset) and its array stride.
#[derive(Debug, Default, Clone)]
struct SpvStruct {
    members: Vec<(String, u32)>,
    size: Option<u32>,
}

/// A minimal SPIR-V reader: names, member offsets, array strides and scalar/vector sizes.
/// The module's words, after checking its magic number.
fn spv_words(spv: &[u8]) -> Vec<u32> {
    let words: Vec<u32> = spv
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(words[0], 0x0723_0203, "SPIR-V magic");
    words
}

/// The module's instructions (after the 5-word header), each with its opcode word first.
fn instructions(words: &[u32]) -> Vec<&[u32]> {
    let mut out = Vec::new();
    let mut i = 5;
    while i < words.len() {
        let count = ((words[i] >> 16) as usize).max(1);
        out.push(&words[i..(i + count).min(words.len())]);
        i += count;
    }
    out
}

/// A literal string operand.
fn string(ws: &[u32]) -> String {
    let bytes: Vec<u8> = ws.iter().flat_map(|w| w.to_le_bytes()).collect();
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

fn reflect(spv: &[u8]) -> HashMap<String, SpvStruct> {
    let words = spv_words(spv);
    let mut names: HashMap<u32, String> = HashMap::new();
    let mut member_names: HashMap<(u32, u32), String> = HashMap::new();
    let mut offsets: HashMap<(u32, u32), u32> = HashMap::new();
    let mut strides: HashMap<u32, u32> = HashMap::new();
    let mut structs: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut arrays: HashMap<u32, u32> = HashMap::new(); // array type -> element type
    let mut sizes: HashMap<u32, u32> = HashMap::new(); // scalar/vector type -> bytes
    for ins in instructions(&words) {
        match ins[0] & 0xffff {
            5 => {
                names.insert(ins[1], string(&ins[2..]));
            }
            6 => {
                member_names.insert((ins[1], ins[2]), string(&ins[3..]));
            }
            71 if ins[2] == 6 => {
                strides.insert(ins[1], ins[3]); // ArrayStride
            }
            72 if ins[3] == 35 => {
                offsets.insert((ins[1], ins[2]), ins[4]); // Offset
            }
            21 | 22 => {
                sizes.insert(ins[1], ins[2] / 8); // OpTypeInt / OpTypeFloat width
            }
            23 => {
                let s = sizes.get(&ins[2]).copied().unwrap_or(0) * ins[3]; // OpTypeVector (of bool: 0)
                sizes.insert(ins[1], s);
            }
            28 | 29 => {
                arrays.insert(ins[1], ins[2]); // OpTypeArray / OpTypeRuntimeArray
            }
            30 => {
                structs.insert(ins[1], ins[2..].to_vec()); // OpTypeStruct
            }
            _ => {}
        }
    }
    // A laid-out struct's size as a member of another (fold.comp's push constants hold
    // LearnParams): its last member's end, nested structs first.
    for _ in 0..4 {
        for (id, members) in &structs {
            let last = members.len() as u32 - 1;
            if let (Some(off), Some(sz)) = (
                offsets.get(&(*id, last)),
                sizes.get(&members[last as usize]).copied(),
            ) {
                sizes.insert(*id, off + sz);
            }
        }
    }
    let mut out = HashMap::new();
    for (id, members) in &structs {
        let Some(name) = names.get(id) else { continue };
        // Only the explicitly laid-out (std430 / push constant) copy of a struct.
        if !offsets.contains_key(&(*id, 0)) {
            continue;
        }
        let mut s = SpvStruct::default();
        for m in 0..members.len() as u32 {
            s.members.push((
                member_names.get(&(*id, m)).cloned().unwrap_or_default(),
                offsets[&(*id, m)],
            ));
        }
        // Size from an array of this struct, else from the last member's end.
        s.size = arrays
            .iter()
            .find(|(_, e)| *e == id)
            .and_then(|(a, _)| strides.get(a).copied())
            .or_else(|| {
                let last = members.len() as u32 - 1;
                sizes
                    .get(&members[last as usize])
                    .map(|sz| offsets[&(*id, last)] + sz)
            });
        out.insert(name.clone(), s);
    }
    out
}

macro_rules! rust_layout {
    ($t:ty { $($f:ident),* $(,)? }) => {
        (
            stringify!($t),
            vec![$((stringify!($f).to_string(), offset_of!($t, $f) as u32)),*],
            size_of::<$t>() as u32,
        )
    };
}

#[test]
fn host_and_shader_structs_match() {
    let mut spv = HashMap::new();
    for render in kernels::render_variants() {
        spv.extend(reflect(render));
    }
    spv.extend(reflect(kernels::TRACE));
    spv.extend(reflect(kernels::LIGHT_SAMPLE));
    spv.extend(reflect(kernels::FOLD));
    spv.extend(reflect(kernels::BSDF));
    spv.extend(reflect(kernels::PREVIEW));
    // The structs kernels read as texels have their explicit layout in texels.comp's output
    // blocks; texel_fetches_rebuild_the_host_bytes checks that the fetches agree with it.
    spv.extend(reflect(kernels::TEXELS));
    let rust = [
        rust_layout!(BvhNode {
            lo_x,
            lo_y,
            lo_z,
            hi_x,
            hi_y,
            hi_z,
            refs
        }),
        rust_layout!(BvhTri {
            v0,
            prim,
            e1,
            pad0,
            e2,
            pad1
        }),
        rust_layout!(GpuLight {
            p0,
            kind,
            p1,
            cos_outer,
            p2,
            cos_inner,
            radiance,
            area
        }),
        rust_layout!(AliasEntry { q, alias, pmf, pad }),
        rust_layout!(GpuMaterial {
            base_color,
            flags,
            emission,
            texture,
            specular_color,
            specular,
            metallic,
            roughness,
            emissive_texture,
            metallic_roughness_texture,
            normal_texture,
            normal_scale,
            alpha_cutoff,
            alpha
        }),
        rust_layout!(GpuTexture {
            offset,
            width,
            height,
            wrap
        }),
        rust_layout!(RenderParams {
            cam_pos,
            cam_u,
            cam_v,
            cam_w,
            width,
            height,
            sample_index,
            seed,
            light_count,
            ray_eps,
            max_depth,
            bounce,
            row0,
            queue_cap,
            passes
        }),
        rust_layout!(GpuRay {
            origin,
            tmin,
            dir,
            tmax
        }),
        rust_layout!(GpuHit { t, prim }),
        rust_layout!(TraceParams {
            ray_count,
            any_hit,
            pad0,
            pad1
        }),
        rust_layout!(PixelAccum { sum, sum_sq }),
        rust_layout!(PreviewParams {
            film_width,
            film_height,
            out_width,
            out_height,
            mean_scale,
            spp,
            view,
            bgra
        }),
        rust_layout!(GpuLightNode {
            centre,
            phi,
            axis,
            cos_o,
            radius,
            sin_o,
            cos_e,
            flags,
            right,
            begin,
            count,
            pad
        }),
        rust_layout!(LightQuery { p, u, n, light }),
        rust_layout!(BsdfQuery {
            n,
            u0,
            v,
            u1,
            l,
            pad,
            material
        }),
        rust_layout!(BsdfResult {
            f,
            pdf,
            sampled,
            sampled_pdf,
            weight,
            p_spec
        }),
        rust_layout!(LightChoice {
            light,
            pmf,
            cv_total,
            cv_chosen,
            pmf_again,
            pmf_query
        }),
        rust_layout!(SlotStats {
            n_zero,
            n_nonzero,
            sum,
            sum_sq,
            scale,
            coef_a,
            coef_b,
            coef_c
        }),
        rust_layout!(SlotDelta {
            n_zero,
            n_nonzero,
            sum_lo,
            sum_hi,
            sq_lo,
            sq_hi,
            touched,
            pad1
        }),
        rust_layout!(LearnParams {
            prior_zero,
            prior_nonzero,
            prior_n,
            prior_alpha,
            prior_cv,
            lambda,
            flags,
            prior_scale,
            defensive
        }),
        rust_layout!(FoldPush {
            slot_count,
            mode,
            first,
            learn
        }),
        rust_layout!(GridParams {
            lo,
            cell,
            dims,
            bins
        }),
    ];
    for (name, fields, size) in rust {
        let s = spv.get(name).unwrap_or_else(|| {
            panic!("struct {name} is not used by any kernel with an explicit layout")
        });
        assert_eq!(
            &s.members, &fields,
            "{name}: member names/offsets differ between Rust and GLSL"
        );
        assert_eq!(
            s.size,
            Some(size),
            "{name}: size differs between Rust and GLSL"
        );
    }
}

/// The checker itself must notice a wrong offset (guards against a test that cannot fail).
#[test]
fn layout_checker_detects_mismatch() {
    let spv = reflect(kernels::TRACE);
    let ray = &spv["GpuRay"];
    let wrong = vec![
        ("origin".to_string(), 0),
        ("tmin".to_string(), 16),
        ("dir".to_string(), 16),
        ("tmax".to_string(), 28),
    ];
    assert_ne!(ray.members, wrong);
    assert_eq!(ray.members[1], ("tmin".to_string(), 12));
    // And the binding check sees a swap.
    let mut swapped = lightlearn::render::FOLD_BINDINGS;
    swapped.swap(0, 1);
    assert_ne!(bindings(kernels::FOLD), named(&swapped));
}

/// (set, binding) → the block (struct type) name of every storage buffer of a module, or
/// the variable's name for a binding of no named type (a texel buffer).
fn bindings(spv: &[u8]) -> Vec<((u32, u32), String)> {
    let words = spv_words(spv);
    let (mut names, mut set, mut binding) = (HashMap::new(), HashMap::new(), HashMap::new());
    let (mut pointee, mut vars) = (HashMap::new(), Vec::new());
    for ins in instructions(&words) {
        match ins[0] & 0xffff {
            5 => {
                names.insert(ins[1], string(&ins[2..]));
            }
            71 if ins[2] == 34 => {
                set.insert(ins[1], ins[3]); // DescriptorSet
            }
            71 if ins[2] == 33 => {
                binding.insert(ins[1], ins[3]); // Binding
            }
            32 => {
                pointee.insert(ins[1], ins[3]); // OpTypePointer: id, storage class, type
            }
            59 => vars.push((ins[2], ins[1])), // OpVariable: result id, pointer type
            _ => {}
        }
    }
    let mut out: Vec<((u32, u32), String)> = vars
        .iter()
        .filter_map(|(v, ptr)| {
            let b = *binding.get(v)?;
            let block = names
                .get(pointee.get(ptr)?)
                .or_else(|| names.get(v))?
                .clone();
            Some(((set.get(v).copied().unwrap_or(0), b), block))
        })
        .collect();
    out.sort();
    out
}

fn named(blocks: &[&str]) -> Vec<((u32, u32), String)> {
    named_sets(&[blocks])
}

fn named_sets(sets: &[&[&str]]) -> Vec<((u32, u32), String)> {
    let mut out: Vec<((u32, u32), String)> = sets
        .iter()
        .enumerate()
        .flat_map(|(s, blocks)| {
            blocks
                .iter()
                .enumerate()
                .map(move |(i, n)| ((s as u32, i as u32), n.to_string()))
        })
        .collect();
    out.sort();
    out
}

#[test]
fn kernels_bind_what_the_session_binds() {
    // Every sampler's two kernels (build.rs strips each, keeping its bindings), and no
    // sampler without them (a seventh would index past build.rs's table).
    use lightlearn::render::LightSampler;
    assert_eq!(
        kernels::render_variants().count(),
        2 * LightSampler::ALL.len()
    );
    for s in LightSampler::ALL {
        for direct in [false, true] {
            assert_eq!(
                bindings(kernels::render(s.shader_id(), direct)),
                named_sets(&lightlearn::render::RENDER_BINDINGS),
                "render.comp's storage blocks and the session's binding list differ ({}, direct only {direct})",
                s.name()
            );
        }
    }
    assert_eq!(
        bindings(kernels::FOLD),
        named(&lightlearn::render::FOLD_BINDINGS),
        "fold.comp's storage blocks and the session's binding list differ"
    );
}

/// Every `#define NAME VALUE` of shaders/shared/types.glsl that mirrors a Rust constant has
/// its value, and the sampler ids are the specialization constants the host passes.
#[test]
fn glsl_defines_match_the_rust_constants() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders/shared/types.glsl"),
    )
    .unwrap();
    let defines: HashMap<String, u32> = text
        .lines()
        .filter_map(|l| {
            let mut w = l.strip_prefix("#define ")?.split_whitespace();
            let (name, value) = (w.next()?, w.next()?.trim_end_matches('u'));
            let v = match value.strip_prefix("0x") {
                Some(hex) => u32::from_str_radix(hex, 16).ok()?,
                None => value.parse().ok()?,
            };
            Some((name.to_string(), v))
        })
        .collect();
    let mut want: Vec<(String, u32)> = vec![
        ("BVH_LEAF_BIT".into(), BVH_LEAF_BIT),
        ("BVH_LEAF_COUNT_SHIFT".into(), BVH_LEAF_COUNT_SHIFT),
        ("BVH_LEAF_FIRST_MASK".into(), BVH_LEAF_FIRST_MASK),
        (
            "BVH_STACK_SIZE".into(),
            lightlearn::accel::bvh::STACK_SIZE as u32,
        ),
        ("LIGHT_POINT".into(), LIGHT_POINT),
        ("LIGHT_SPOT".into(), LIGHT_SPOT),
        ("LIGHT_TRIANGLE".into(), LIGHT_TRIANGLE),
        ("LIGHT_TWO_SIDED".into(), LIGHT_TWO_SIDED),
        ("LIGHT_TEXTURED".into(), LIGHT_TEXTURED),
        ("LIGHT_DIRECTIONAL".into(), LIGHT_DIRECTIONAL),
        ("LIGHT_NODE_TWO_SIDED".into(), LIGHT_NODE_TWO_SIDED),
        ("LIGHT_NODE_AREA".into(), LIGHT_NODE_AREA),
        ("LEARN_REGRESSION".into(), LEARN_REGRESSION),
        ("LEARN_TARGET_MEAN".into(), LEARN_TARGET_MEAN),
        ("LEARN_PRIORS".into(), LEARN_PRIORS),
        ("LEARN_BRDF".into(), LEARN_BRDF),
        ("LEARN_CONTROL_VARIATES".into(), LEARN_CONTROL_VARIATES),
        ("LEARN_BRDF_SELECT".into(), LEARN_BRDF_SELECT),
        ("LEARN_REGRESS_IMPORTANCE".into(), LEARN_REGRESS_IMPORTANCE),
        ("LEARN_DEFENSIVE".into(), LEARN_DEFENSIVE),
        ("LEARN_REFINE".into(), LEARN_REFINE),
        ("MATERIAL_TWO_SIDED".into(), MATERIAL_TWO_SIDED),
        ("TEXTURE_NEAREST".into(), TEXTURE_NEAREST),
        ("TEXTURE_16_BIT".into(), TEXTURE_16_BIT),
    ];
    use lightlearn::render::Stratify;
    for s in [Stratify::Off, Stratify::R2, Stratify::Sobol] {
        want.push((format!("STRATIFY_{}", s.name().to_uppercase()), s.code()));
    }
    for s in lightlearn::render::LightSampler::ALL {
        want.push((
            format!("SAMPLER_{}", s.name().to_uppercase()),
            s.shader_id(),
        ));
    }
    for (name, value) in want {
        assert_eq!(
            defines.get(&name),
            Some(&value),
            "{name}: types.glsl and the Rust constant differ"
        );
    }
}

/// naga (an independent SPIR-V reader) agrees with ours on every struct of the kernels it
/// can parse. naga 30 rejects OpCopyLogical (SPIR-V 1.4), which glslang emits for our
/// vulkan1.2 builds, so those kernels are compiled here once more for SPIR-V 1.0 (the same
/// source, so the same layouts); render.comp and light_sample.comp use OpSpecConstantOp,
/// which naga rejects at any version, and trace.comp and fold.comp texel buffers
/// (SampledBuffer), which naga rejects too: they stay with our reader alone.
#[test]
fn naga_agrees_with_our_reader() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    // texels.comp and bsdf.comp (its layer albedo table) without their texel buffers
    // (LAYOUT_ONLY): naga 30 refuses the SampledBuffer capability, which also keeps
    // trace.comp out.
    for (name, shipped, defines) in [
        ("texels", kernels::TEXELS, &["-DLAYOUT_ONLY"][..]),
        ("bsdf", kernels::BSDF, &["-DLAYOUT_ONLY"][..]),
    ] {
        let out = dir.path().join(format!("{name}.spv"));
        let status = std::process::Command::new("glslangValidator")
            .args(["-V", "--target-env", "vulkan1.0"])
            .args(defines)
            .arg(format!("-I{}", root.join("shaders/shared").display()))
            .arg(root.join(format!("shaders/{name}.comp")))
            .arg("-o")
            .arg(&out)
            .output()
            .expect("glslangValidator (ci/setup.sh installs it; build.rs needs it too)");
        assert!(status.status.success(), "{name}: {status:?}");
        let module = naga::front::spv::parse_u8_slice(
            &std::fs::read(&out).unwrap(),
            &naga::front::spv::Options::default(),
        )
        .unwrap_or_else(|e| panic!("naga cannot parse {name}.comp for SPIR-V 1.0: {e:?}"));
        // Every explicitly laid-out struct our reader finds in the shipped module: naga has a
        // struct of that name with the same member names and offsets, and its size.
        for (tname, mine) in reflect(shipped) {
            let agrees = module
                .types
                .iter()
                .any(|(_, ty)| match (&ty.name, &ty.inner) {
                    (Some(n), naga::TypeInner::Struct { members, span }) if *n == tname => {
                        let theirs: Vec<(String, u32)> = members
                            .iter()
                            .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                            .collect();
                        theirs == mine.members
                            && mine
                                .size
                                .is_none_or(|z| *span == z || *span == z.next_multiple_of(16))
                    }
                    _ => false,
                });
            assert!(
                agrees,
                "{name}: naga and our reader differ on {tname} ({mine:?})"
            );
            checked += 1;
        }
    }
    eprintln!("naga and our reader agree on {checked} structs");
    assert!(checked >= 6, "only {checked} structs compared");
}

/// The kernels read the BVH, the light tree, the cuts, the region index and the statistics
/// as texels (src/gpu/buffer.rs `Buffer::texels`, `Buffer::words`): each fetch function must
/// rebuild the host's struct bit for bit. texels.comp fetches random bytes through every one
/// and writes the structs to storage buffers with the layout host_and_shader_structs_match
/// checks; the bytes must come back unchanged (a swapped member or texel fails this).
#[test]
fn texel_fetches_rebuild_the_host_bytes() {
    let ctx = common::ctx();
    let mut r = SplitMix64(7);
    const N: usize = 200;
    // Random words that are normal floats when read as floats (a NaN or denormal could be
    // changed by a float move on some devices; the fetches never do arithmetic).
    let mut words = |n: usize| -> Vec<u32> {
        (0..n)
            .map(|_| {
                let w = (r.next_u64() >> 32) as u32;
                let exponent = 1 + (w >> 23 & 0xff) % 254;
                (w & 0x807f_ffff) | exponent << 23
            })
            .collect()
    };
    let nodes = words(N * size_of::<BvhNode>() / 4);
    let tris = words(N * size_of::<BvhTri>() / 4);
    let light_nodes = words(N * size_of::<GpuLightNode>() / 4);
    let stats = words(N * size_of::<SlotStats>() / 4);
    let cut = words(N);
    let index = words(N);
    let lights = words(N * size_of::<GpuLight>() / 4);
    let materials = words(N * size_of::<GpuMaterial>() / 4);
    let grid = words(size_of::<GridParams>() / 4);
    let texels = |name: &str, w: &[u32]| {
        Buffer::texels(&ctx, name, bytemuck::cast_slice::<u32, [u32; 4]>(w)).unwrap()
    };
    let ins = [
        texels("nodes", &nodes),
        texels("tris", &tris),
        texels("light nodes", &light_nodes),
        texels("stats", &stats),
        Buffer::words(&ctx, "cuts", &cut).unwrap(),
        Buffer::words(&ctx, "region index", &index).unwrap(),
    ];
    let out = |w: &[u32]| Buffer::zeroed(&ctx, "out", 4 * w.len() as u64).unwrap();
    let outs = [
        out(&nodes),
        out(&tris),
        out(&light_nodes),
        out(&stats),
        out(&[0; 2 * N]),
    ];
    let order = Buffer::from_slice(&ctx, "order", &[0u32]).unwrap();
    let scene_ins = [
        texels("lights", &lights),
        texels("materials", &materials),
        texels("grid", &grid),
    ];
    let scene_outs = [out(&lights), out(&materials), out(&grid)];
    let k = ComputePipeline::new(&ctx, "texels", kernels::TEXELS, 18, 28, &[]).unwrap();
    let mut bound: Vec<&Buffer> = ins.iter().chain(outs.iter()).collect();
    bound.push(&order);
    bound.extend(scene_ins.iter().chain(scene_outs.iter()));
    k.bind(&bound).unwrap();
    let counts = [N as u32; 7];
    ctx.submit(|cmd| {
        k.dispatch(
            cmd,
            bytemuck::cast_slice(&counts),
            [(N as u32).div_ceil(64), 1, 1],
        )
    })
    .unwrap();
    for (name, want, got) in [
        ("BvhNode", &nodes, &outs[0]),
        ("BvhTri", &tris, &outs[1]),
        ("GpuLightNode", &light_nodes, &outs[2]),
        ("SlotStats", &stats, &outs[3]),
        ("GpuLight", &lights, &scene_outs[0]),
        ("GpuMaterial", &materials, &scene_outs[1]),
        ("GridParams", &grid, &scene_outs[2]),
    ] {
        assert_eq!(
            &got.read::<u32>().unwrap(),
            want,
            "{name}: the texel fetch changed the bytes"
        );
    }
    let pairs: Vec<u32> = outs[4].read().unwrap();
    let cut_back: Vec<u32> = pairs.iter().step_by(2).copied().collect();
    let index_back: Vec<u32> = pairs.iter().skip(1).step_by(2).copied().collect();
    assert_eq!(cut_back, cut, "cut words");
    assert_eq!(index_back, index, "region index words");
}
