//! Compiles every `shaders/*.comp` to SPIR-V in OUT_DIR with glslangValidator
//! (`--target-env vulkan1.2`: vulkan1.3 output needs maintenance4, which lavapipe in Debian 12
//! and naga do not take).

use std::path::{Path, PathBuf};
use std::process::Command;

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
        let dst = out.join(format!("{stem}.spv"));
        let result = Command::new("glslangValidator")
            .args(["-V", "--target-env", "vulkan1.2", "-Ishaders/shared", "-o"])
            .arg(&dst)
            .arg(src)
            .output();
        match result {
            Err(e) => panic!(
                "\n\nglslangValidator not found ({e}).\nRun `ci/setup.sh` (it installs glslang-tools), then build again.\n\n"
            ),
            Ok(o) if !o.status.success() => panic!(
                "\n\nshader {} failed to compile:\n{}{}\n",
                src.display(),
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
            Ok(_) => {}
        }
    }
}
