//! Checks before any work: that an output can be written and spares the inputs, and reads
//! of regular files only (a FIFO would block the reader, a link to /dev/zero never end).

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};

use super::{check_parent, folder_of, temp_path};

/// Fails early, before any work, unless `p` can be written: its folder exists and takes new
/// files, `p` itself is not a folder, a device, a FIFO or a socket (the rename would replace
/// it: `merge-stats --out /dev/null --force` as root replaced the system's /dev/null), and
/// its name is not longer than the file system takes. (Measured before: `--out` naming a
/// folder failed only after the whole render; a 300-byte name, or a 255-byte EXR name whose
/// JSON is 256, passed the probe and lost the render at its end.)
pub fn check_writable(p: &Path) -> Result<()> {
    // `x.exr/` names a folder to the file system but `x.exr` to the path's parts: it passed
    // these checks and the render, then failed at its write (a reference was lost whole; an
    // audit, 2026-12-07).
    use std::os::unix::ffi::OsStrExt;
    let bytes = p.as_os_str().as_bytes();
    let last = bytes.rsplit(|&c| c == b'/').next().unwrap_or(b"");
    if bytes.ends_with(b"/") || last == b"." || last == b".." {
        bail!(
            "cannot write '{}': it ends in a slash (or '.' or '..'), which names a folder; name a file",
            p.display()
        );
    }
    check_parent(p)?;
    if p.is_dir() {
        bail!(
            "cannot write '{}': it is a folder; name a file instead",
            p.display()
        );
    }
    check_not_special(p)?;
    let probe = temp_path(p).with_extension("probe");
    std::fs::write(&probe, b"").map_err(|e| {
        anyhow::anyhow!(
            "cannot write '{}': {} ({e})",
            p.display(),
            why_not_written(&e)
        )
    })?;
    let _ = std::fs::remove_file(&probe);
    // The name's length, with a new file of a name as long (never the target itself).
    let len = p.file_name().map_or(0, |n| n.len());
    let stem = format!(".{}.probe-", std::process::id());
    if len > stem.len() {
        let probe = p.with_file_name(format!("{stem}{}", "x".repeat(len - stem.len())));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&probe)
        {
            Ok(_) => {
                let _ = std::fs::remove_file(&probe);
            }
            Err(e) if e.raw_os_error() == Some(libc::ENAMETOOLONG) => bail!(
                "cannot write '{}': its name is {len} bytes, more than its file system takes (255 on most); shorten the name",
                p.display()
            ),
            Err(_) => {}
        }
    }
    Ok(())
}

/// Refuses an output path that is a device, a FIFO or a socket, or a link to one: the rename
/// would replace it (`merge-stats --out /dev/null --force`, as root, replaced the system's
/// /dev/null; through a link, /dev/stdout). Called before any "add --force" advice, which
/// cannot help here.
pub fn check_not_special(p: &Path) -> Result<()> {
    let special = |t: std::fs::FileType| !t.is_file() && !t.is_dir() && !t.is_symlink();
    let Ok(m) = std::fs::symlink_metadata(p) else {
        return Ok(()); // nothing there yet
    };
    let linked = m.file_type().is_symlink();
    let target = if linked {
        std::fs::metadata(p).ok().map(|m| m.file_type())
    } else {
        Some(m.file_type())
    };
    if target.is_some_and(special) {
        bail!(
            "cannot write '{}': it is not a regular file (a device, FIFO or socket{}) and would be replaced; name a file instead",
            p.display(),
            if linked { ", through a link" } else { "" }
        );
    }
    Ok(())
}

/// What a failed write means, and what to do (one clause of an error line).
pub fn why_not_written(e: &std::io::Error) -> &'static str {
    match e.raw_os_error() {
        Some(libc::EROFS) => "its file system is read-only; write elsewhere",
        Some(libc::ENOSPC) | Some(libc::EDQUOT) => {
            "the disk is full; free space or write elsewhere"
        }
        Some(libc::EACCES) | Some(libc::EPERM) => {
            "no permission to create files in its folder; write elsewhere"
        }
        Some(libc::ENOENT) => "its folder no longer exists",
        Some(libc::ENOTDIR) => "part of its path is a file, not a folder",
        Some(libc::ENAMETOOLONG) => "its name or path is too long; shorten it",
        _ => "its folder does not take new files",
    }
}

/// Refuses outputs that are one of the command's inputs (`what`, path): a scene named like
/// a report (`s.json`) was replaced by the report, with exit 0.
pub fn check_outputs_spare_inputs(outputs: &[&Path], inputs: &[(&str, &Path)]) -> Result<()> {
    for o in outputs {
        if let Some((what, i)) = inputs.iter().find(|(_, i)| same_path(o, i)) {
            anyhow::bail!(
                "--out would write '{}', which is {what} '{}' this command reads; name another --out",
                o.display(),
                i.display()
            );
        }
    }
    Ok(())
}

/// The regular file at `path`, opened, and its length: anything else (a folder, a FIFO that
/// would block, a device such as /dev/zero that never ends) is refused before it is opened
/// (each of these hung or filled memory as a scene, buffer, statistics file, report or EXR).
pub fn open_regular(path: &Path) -> std::io::Result<(std::fs::File, u64)> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    Ok((std::fs::File::open(path)?, meta.len()))
}

/// The first `max` bytes of the regular file at `path` ([`open_regular`]).
pub fn read_regular(path: &Path, max: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let (file, len) = open_regular(path)?;
    let mut bytes = Vec::new();
    // A sparse file of a terabyte aborted the process in `with_capacity`: an error instead.
    bytes
        .try_reserve_exact(len.min(max) as usize)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::OutOfMemory, "too large to read"))?;
    file.take(max).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// All of the regular file at `path` ([`read_regular`]).
pub fn read_all(path: &Path) -> std::io::Result<Vec<u8>> {
    read_regular(path, u64::MAX)
}

/// [`check_outputs_spare_inputs`] against the scene `scene` (with the buffers and images it
/// names) and `others`; the scene's files, for a caller that needs them too (they are read
/// from the file once).
pub fn check_outputs_spare_scene(
    outputs: &[&Path],
    scene: Option<&Path>,
    others: &[(&str, &Path)],
) -> Result<Vec<PathBuf>> {
    let files = scene
        .map(crate::scene::gltf_load::input_files)
        .unwrap_or_default();
    let mut inputs: Vec<(&str, &Path)> = files
        .iter()
        .enumerate()
        .map(|(i, f)| {
            (
                if i == 0 {
                    "the scene"
                } else {
                    "a file of the scene"
                },
                f.as_path(),
            )
        })
        .collect();
    inputs.extend_from_slice(others);
    check_outputs_spare_inputs(outputs, &inputs)?;
    Ok(files)
}

/// Whether `a` and `b` name the same file (also when neither exists yet: their folders and
/// names are compared).
pub fn same_path(a: &Path, b: &Path) -> bool {
    let full = |p: &Path| -> Option<PathBuf> {
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let dir = folder_of(p);
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    };
    match (full(a), full(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}
