//! Hidden temporaries: their names beside their targets, the stale ones of dead processes,
//! and the ones a quick exit removes.

use std::path::{Path, PathBuf};

/// A hidden temporary name in the same folder as `p` (renames stay on one file system).
/// A long name keeps its first 96 bytes and a hash of the whole: the prefix and suffix
/// took a 246-character name (legal) past the 255 bytes a file system allows, and the
/// output was refused with a permissions hint.
/// Built from the name's bytes: a lossy text made two names that differ only in bytes
/// that are not UTF-8 share one temporary, and a render lost its samples (an audit,
/// 2026-12-07: `--out a\xff.exr --save-stats a\xfe.exr`).
pub fn temp_path(p: &Path) -> PathBuf {
    use std::os::unix::ffi::{OsStrExt, OsStringExt};
    let name = p.file_name().map_or(&[][..], |n| n.as_bytes());
    let mut temp = b".".to_vec();
    if name.len() > 128 {
        let hash = crate::fnv::fnv1a(name);
        // At a character's boundary where the name is text.
        let cut = if std::str::from_utf8(name).is_ok() {
            (0..=96)
                .rev()
                .find(|&i| std::str::from_utf8(&name[..i]).is_ok())
                .unwrap_or(0)
        } else {
            96
        };
        temp.extend_from_slice(&name[..cut]);
        temp.extend_from_slice(format!("-{hash:016x}").as_bytes());
    } else {
        temp.extend_from_slice(name);
    }
    temp.extend_from_slice(format!(".{}.tmp", std::process::id()).as_bytes());
    p.with_file_name(std::ffi::OsString::from_vec(temp))
}

/// The folder `p` is in ("." for a bare name).
pub(crate) fn folder_of(p: &Path) -> &Path {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Removes the temporaries of `p` that a killed process left (`render --checkpoint`: a
/// SIGKILL during a write leaves them, the outputs themselves whole): those named by
/// [`temp_path`] for a process id that no longer runs here, untouched for 10 minutes (a
/// writer on another machine of a shared folder looks dead here, and writes its temporary
/// in seconds). Only where /proc tells which processes run. Never [`super::commit_all`]'s second
/// names: after a failed restore one may be the only copy of an old file.
pub fn remove_stale_temps(p: &Path) {
    const STALE_SECONDS: u64 = 600;
    let ours = temp_path(p);
    let Some(ours) = ours.file_name().and_then(|n| n.to_str()) else {
        return;
    };
    let pid = std::process::id().to_string();
    let Some(prefix) = ours.strip_suffix(&format!("{pid}.tmp")) else {
        return;
    };
    let dir = folder_of(p);
    if !Path::new("/proc/self").exists() {
        return;
    }
    // A folder is listed once a process, its hidden `.tmp` names kept: `animate` listed its
    // folder five times a frame, 39 % of a run of tiny frames with 10000 frames there
    // (+190 ms a frame; an audit, 2026-12-07). Temporaries left later by other processes
    // wait for the next run.
    static LISTED: std::sync::Mutex<Vec<(PathBuf, Vec<String>)>> =
        std::sync::Mutex::new(Vec::new());
    let mut listed = LISTED.lock().unwrap_or_else(|e| e.into_inner());
    let at = match listed.iter().position(|(d, _)| d == dir) {
        Some(i) => i,
        None => {
            let Ok(entries) = std::fs::read_dir(dir) else {
                return;
            };
            let names = entries
                .flatten()
                .filter_map(|e| e.file_name().into_string().ok())
                .filter(|n| n.starts_with('.') && n.ends_with(".tmp"))
                .collect();
            listed.push((dir.to_path_buf(), names));
            listed.len() - 1
        }
    };
    listed[at].1.retain(|name| {
        let Some(other) = name
            .strip_prefix(prefix)
            .and_then(|n| n.strip_suffix(".tmp"))
        else {
            return true;
        };
        let dead = !other.is_empty()
            && other.bytes().all(|b| b.is_ascii_digit())
            && other != pid
            && !Path::new("/proc").join(other).exists();
        let path = dir.join(name);
        let idle = std::fs::symlink_metadata(&path)
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age.as_secs() >= STALE_SECONDS);
        if dead && idle {
            let _ = std::fs::remove_file(&path);
            return false;
        }
        true
    });
}

/// The temporaries this process is writing or holds until a commit, and the output folders
/// it made for a command still running: a second Ctrl-C (or one outside a pass loop) ends
/// the process at once (`crate::interrupt::quick_exit`), which removes them first
/// ([`remove_pending`]). Without, `scene` and `variance` stopped in their writes left
/// full-size hidden temporaries (270 MB for a million-light scene) and empty folders (an
/// audit, 2026-12-07).
static PENDING: std::sync::Mutex<(Vec<PathBuf>, Vec<PathBuf>)> =
    std::sync::Mutex::new((Vec::new(), Vec::new()));

fn pending() -> std::sync::MutexGuard<'static, (Vec<PathBuf>, Vec<PathBuf>)> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

pub(super) fn track_temp(tmp: &Path) {
    pending().0.push(tmp.to_path_buf());
}

pub(super) fn untrack_temp(tmp: &Path) {
    let mut p = pending();
    if let Some(i) = p.0.iter().rposition(|t| t == tmp) {
        p.0.swap_remove(i);
    }
}

/// Removes the temporaries being written and the empty output folders of a command still
/// running: for a signal handler about to end the process at once.
pub fn remove_pending() {
    let p = pending();
    for t in &p.0 {
        let _ = std::fs::remove_file(t);
    }
    for d in &p.1 {
        let _ = std::fs::remove_dir(d); // only if still empty
    }
}

/// Folders a running command made, removed by a quick exit where still empty.
pub(super) fn track_folders(made: &[PathBuf]) {
    pending().1.extend(made.iter().cloned());
}

pub(super) fn untrack_folders(made: &[PathBuf]) {
    pending().1.retain(|d| !made.contains(d));
}
