//! Files written so that a failure never leaves a half-written output: write to a hidden
//! temporary file beside the target, then rename.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

/// A hidden temporary name in the same folder as `p` (renames stay on one file system).
pub fn temp_path(p: &Path) -> PathBuf {
    let name = p
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    p.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Fails early, before any work, when `p`'s folder does not exist.
pub fn check_parent(p: &Path) -> Result<()> {
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!(
            "cannot write '{}': folder '{}' does not exist; create it first",
            p.display(),
            dir.display()
        );
    }
    Ok(())
}

/// Writes `bytes` to `p` atomically.
pub fn write_atomic(p: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(p, |tmp| Ok(std::fs::write(tmp, bytes)?))
}

/// Lets `write` fill a temporary file, then renames it to `p`; removes it on failure.
pub fn write_atomic_with(p: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(p);
    let result = write(&tmp)
        .and_then(|_| Ok(std::fs::rename(&tmp, p)?))
        .with_context(|| format!("cannot write '{}'", p.display()));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
