//! Compiles every `shaders/*.comp` to SPIR-V in OUT_DIR with glslangValidator
//! (`--target-env vulkan1.2`: vulkan1.3 output needs maintenance4, which lavapipe in Debian 12
//! and naga do not take). render.comp is compiled once per light sampler and per
//! DIRECT_ONLY (`render_s{S}_d{D}.spv`, src/gpu/mod.rs `kernels::render`), each stripped of the
//! code the others need by spirv-opt: lavapipe inlines every function a kernel calls before it
//! drops the branches its specialization constants rule out, so one kernel holding all six
//! samplers took it 0.8–1.1 s to build in every process, one sampler's 0.3–0.4 s (the same
//! images; docs/results.md, twenty-second session).

use std::path::{Path, PathBuf};
use std::process::Command;

/// The light samplers (render.comp SAMPLER: src/render/mod.rs `LightSampler::shader_id`).
const SAMPLERS: u32 = 6;

/// spirv-opt's passes for a render kernel: branches on constants, the code only they reached
/// and the functions nothing calls any more. No constant folding of values (the arithmetic
/// stays as glslang wrote it, so the images keep their bits); the bindings and the remaining
/// specialization constants stay declared, so every variant has the same interface.
const STRIP: &[&str] = &[
    "--eliminate-dead-branches",
    "--eliminate-dead-code-aggressive",
    "--eliminate-dead-functions",
    "--preserve-bindings",
    "--preserve-spec-constants",
];

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let shaders = Path::new("shaders");
    println!("cargo:rerun-if-changed=shaders");
    let mut entries: Vec<PathBuf> = std::fs::read_dir(shaders)
        .expect("shaders/ folder")
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for dir in [shaders.join("shared")] {
        for e in std::fs::read_dir(dir).expect("shaders/shared") {
            println!("cargo:rerun-if-changed={}", e.unwrap().path().display());
        }
    }
    for src in entries
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "comp"))
    {
        println!("cargo:rerun-if-changed={}", src.display());
        let stem = src.file_stem().unwrap().to_str().unwrap();
        let result = if stem == "render" {
            // Twelve compiler runs of ~0.4 s each, side by side; the first error stops the
            // build (once, not once a kernel).
            std::thread::scope(|s| {
                let jobs: Vec<_> = (0..SAMPLERS)
                    .flat_map(|sampler| [false, true].map(|direct| (sampler, direct)))
                    .map(|(sampler, direct)| {
                        let dst = out.join(format!("render_s{sampler}_d{}.spv", direct as u32));
                        s.spawn(move || {
                            glslang(
                                src,
                                &dst,
                                &[
                                    &format!("-DFIXED_SAMPLER={sampler}u"),
                                    &format!("-DFIXED_DIRECT_ONLY={direct}"),
                                ],
                            )?;
                            strip(&dst)
                        })
                    })
                    .collect();
                // The scope waits for every job; the first error is the one reported.
                jobs.into_iter()
                    .try_for_each(|j| j.join().expect("a compiler job"))
            })
        } else {
            glslang(src, &out.join(format!("{stem}.spv")), &[])
        };
        if let Err(e) = result {
            panic!("{e}");
        }
    }
}

/// glslangValidator `src` → `dst` with the preprocessor definitions `defines`.
fn glslang(src: &Path, dst: &Path, defines: &[&str]) -> Result<(), String> {
    let mut cmd = Command::new("glslangValidator");
    cmd.args(["-V", "--target-env", "vulkan1.2", "-Ishaders/shared"])
        .args(defines)
        .arg("-o")
        .arg(dst)
        .arg(src);
    let what = format!("shader {} {defines:?}", src.display());
    run(cmd, "glslang-tools", &what)
}

/// spirv-opt [`STRIP`] on `spv` in place.
fn strip(spv: &Path) -> Result<(), String> {
    let mut cmd = Command::new("spirv-opt");
    cmd.args(STRIP).arg(spv).arg("-o").arg(spv);
    run(
        cmd,
        "spirv-tools",
        &format!("spirv-opt on {}", spv.display()),
    )
}

/// Runs a tool of the Debian package `package`: Err with what to install, or with what the
/// tool printed.
fn run(mut cmd: Command, package: &str, what: &str) -> Result<(), String> {
    let tool = cmd.get_program().to_string_lossy().into_owned();
    match cmd.output() {
        Err(e) => Err(format!(
            "\n\n{tool} not found ({e}).\nRun `ci/setup.sh` (it installs {package}), then build again.\n\n"
        )),
        Ok(o) if !o.status.success() => Err(format!(
            "\n\n{what} failed:\n{}{}\n",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )),
        Ok(_) => Ok(()),
    }
}
