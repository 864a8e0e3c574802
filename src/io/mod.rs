//! Files written so that a failure never leaves a half-written output: write to a hidden
//! temporary file beside the target, then rename.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

mod checks;
mod temps;
pub use checks::*;
pub(crate) use temps::folder_of;
pub use temps::{remove_pending, remove_stale_temps, temp_path};
use temps::{track_folders, track_temp, untrack_folders, untrack_temp};

/// The nearest part of `dir` that exists (`dir` itself or a folder above it), where that is
/// not a folder: a path under it can never be created.
fn not_a_folder(dir: &Path) -> Option<&Path> {
    dir.ancestors()
        .find(|a| !a.as_os_str().is_empty() && std::fs::symlink_metadata(a).is_ok())
        .filter(|a| !a.is_dir())
}

/// Refuses a path that starts with a `~` folder that does not exist: the shell expands `~`
/// only unquoted at a word's start (`--out ~/x`, not `--out=~/x`), and lightlearn never
/// does, so such a path made a folder named `~` in the working folder, or was refused as
/// "folder '~' does not exist; create it first" (an audit, 2026-12-07).
fn check_tilde(p: &Path) -> Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let Some(std::path::Component::Normal(first)) = p.components().next() else {
        return Ok(());
    };
    // `~`, and `~user/…` (a file or folder of its own named `~draft.exr` is a name).
    let home = first.as_bytes() == b"~"
        || first.as_bytes().starts_with(b"~") && p.components().count() > 1;
    if home && std::fs::symlink_metadata(first).is_err() {
        bail!(
            "'{}' starts with '~', which lightlearn does not expand (the shell does only at the start of a word: `--out ~/x`, not `--out=~/x`); give the home folder's path",
            p.display()
        );
    }
    Ok(())
}

/// Fails early, before any work, when `p`'s folder does not exist.
pub fn check_parent(p: &Path) -> Result<()> {
    check_tilde(p)?;
    let dir = folder_of(p);
    // A file where a folder of the path should be was reported as a missing folder, and
    // `--mkdir` then failed with "File exists" (an audit, 2026-12-06).
    if let Some(f) = not_a_folder(dir) {
        bail!(
            "cannot write '{}': '{}' is not a folder (a file or something else of that name is there); name another path",
            p.display(),
            f.display()
        );
    }
    if !dir.is_dir() {
        bail!(
            "cannot write '{}': folder '{}' does not exist; create it first",
            p.display(),
            dir.display()
        );
    }
    Ok(())
}

/// Creates the output folder `dir` (and missing parents), `what` naming it in errors: a
/// file, FIFO or link of that name is named as such (it was "File exists (os error 17)"),
/// and a failure says why where it can.
pub fn create_output_folder(dir: &Path, what: &str) -> Result<()> {
    check_tilde(dir)?;
    if let Some(f) = not_a_folder(dir) {
        bail!(
            "cannot create the {what} '{}': '{}' is something else than a folder (a file, a FIFO or a link to nothing); name another --out",
            dir.display(),
            f.display()
        );
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        anyhow::anyhow!(
            "cannot create the {what} '{}': {} ({e})",
            dir.display(),
            why_not_written(&e)
        )
    })
}

/// Runs `f`, which may create the folder `out` (and missing parents); if it fails, the
/// folders it created are removed again where still empty, so a failed command leaves no
/// empty output folder behind.
pub fn removing_created_folders_on_error<T>(
    out: Option<&Path>,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    // The folders this run creates (the output folder and missing parents), innermost first.
    let created: Vec<PathBuf> = out
        .into_iter()
        .flat_map(Path::ancestors)
        .take_while(|p| !p.as_os_str().is_empty() && !p.exists())
        .map(Path::to_path_buf)
        .collect();
    track_folders(&created);
    let result = f();
    untrack_folders(&created);
    if result.is_err() {
        for d in &created {
            let _ = std::fs::remove_dir(d); // only if still empty
        }
    }
    result
}

/// Writes `bytes` to `p` atomically.
pub fn write_atomic(p: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(p, |tmp| Ok(std::fs::write(tmp, bytes)?))
}

/// Lets `write` fill a temporary file, then renames it to `p`; removes it on failure.
pub fn write_atomic_with(p: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = write_temp(p, write)?;
    // A quick exit waits for the rename (crate::interrupt::Writing).
    let _whole = crate::interrupt::Writing::begin();
    let result = std::fs::rename(&tmp, p).map_err(|e| {
        let e = anyhow::Error::new(e);
        let what = write_failed(p, &e);
        e.context(what)
    });
    // The folder's flush is not waited for (a slow disk would hold every Ctrl-C off).
    drop(_whole);
    match result {
        Ok(()) => sync_folder(p),
        Err(_) => {
            let _ = std::fs::remove_file(&tmp);
        }
    }
    untrack_temp(&tmp);
    result
}

/// Lets `write` fill the temporary of `target` (stale ones of dead processes removed first)
/// and flushes it; its name, or the error with what to do, the temporary removed.
fn write_temp(target: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<PathBuf> {
    remove_stale_temps(target);
    let tmp = temp_path(target);
    track_temp(&tmp);
    match write(&tmp).and_then(|_| sync_file(&tmp)) {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            untrack_temp(&tmp);
            let what = write_failed(target, &e);
            Err(e.context(what))
        }
    }
}

/// "cannot write 'p'", with what to do where the cause says (a full disk, a read-only file
/// system): the audit's disk-full errors named the file but not the fix.
fn write_failed(p: &Path, e: &anyhow::Error) -> String {
    let io = e
        .chain()
        .find_map(|c| c.downcast_ref::<std::io::Error>())
        .filter(|io| {
            matches!(
                io.raw_os_error(),
                Some(libc::ENOSPC) | Some(libc::EDQUOT) | Some(libc::EROFS)
            )
        });
    match io {
        Some(io) => format!("cannot write '{}': {}", p.display(), why_not_written(io)),
        None => format!("cannot write '{}'", p.display()),
    }
}

/// Flushes a written temporary to the disk before it is renamed over an old file: without,
/// a crash soon after the rename can leave an empty file under the final name on some file
/// systems, the old one gone.
fn sync_file(tmp: &Path) -> Result<()> {
    match std::fs::File::open(tmp)?.sync_all() {
        // A file system that cannot flush (EINVAL, ENOTSUP) has nothing to wait for.
        Err(e) if matches!(e.raw_os_error(), Some(libc::EINVAL) | Some(libc::ENOTSUP)) => Ok(()),
        r => Ok(r?),
    }
}

/// Flushes `p`'s folder (its renames); best effort.
fn sync_folder(p: &Path) {
    let dir = folder_of(p);
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Moves every written temporary file onto its target together: each file already there
/// first gets a second name (a hard link, or a copy where links are not possible), then each
/// temporary is renamed over its target (an atomic replace, so a target never goes missing,
/// even if the program is killed), and if any move fails, the old files are renamed back
/// and the new ones that had no predecessor are removed. So a failure leaves the old set,
/// never a mix. The temporaries are removed on failure.
pub fn commit_all(files: &[(PathBuf, PathBuf)]) -> Result<()> {
    let _locks = FolderLocks::take(files.iter().map(|(t, _)| t.as_path()), false);
    // The moves together, never cut by a quick exit (crate::interrupt::Writing), which
    // waits for them (not for the locks): `variance` stopped between two of its renames
    // paired new maps with the old report (an audit, 2026-12-07).
    let _whole = crate::interrupt::Writing::begin();
    let backup = |p: &Path| temp_path(p).with_extension("old");
    let mut kept: Vec<&Path> = Vec::new(); // targets with a second name of their old file
    let mut moved: Vec<&Path> = Vec::new(); // targets that hold the new file
    let result = (|| -> Result<()> {
        for (target, _) in files {
            if target.exists() {
                let b = backup(target);
                let _ = std::fs::remove_file(&b);
                std::fs::hard_link(target, &b)
                    .or_else(|_| std::fs::copy(target, &b).map(|_| ()))
                    .with_context(|| format!("cannot keep the old '{}'", target.display()))?;
                kept.push(target);
            }
        }
        for (target, tmp) in files {
            std::fs::rename(tmp, target)
                .with_context(|| format!("cannot move the result into '{}'", target.display()))?;
            moved.push(target);
        }
        // The second names go before the folders' flush, not after: a process killed during
        // the flush (milliseconds) left them behind, a full copy of the old outputs each,
        // which nothing removed (2 of 25 kills of a checkpointing render: an audit,
        // 2026-12-07). They are needed only to undo a failed move.
        for t in &kept {
            let _ = std::fs::remove_file(backup(t));
        }
        Ok(())
    })();
    // The set is whole here; the folders' flush is not waited for by a quick exit.
    if result.is_ok() {
        drop(_whole);
        _locks.sync();
    }
    let mut failed_restore = Vec::new();
    if result.is_err() {
        for t in &moved {
            if !kept.contains(t) {
                let _ = std::fs::remove_file(t);
            }
        }
        for t in &kept {
            if moved.contains(t) && std::fs::rename(backup(t), t).is_err() {
                failed_restore.push(t.display().to_string());
            }
        }
        for (_, tmp) in files {
            let _ = std::fs::remove_file(tmp);
        }
        // (A commit that succeeded removed its second names before the flush.) A backup
        // that could not be put back stays: it is the only copy of the old file.
        for t in &kept {
            if !failed_restore.contains(&t.display().to_string()) {
                let _ = std::fs::remove_file(backup(t));
            }
        }
    }
    for (_, tmp) in files {
        untrack_temp(tmp);
    }
    match result {
        Err(e) if !failed_restore.is_empty() => Err(e.context(format!(
            "and the old {} could not be put back",
            failed_restore.join(", ")
        ))),
        r => r,
    }
}

/// A lock (flock) on the file `path` (created, never removed: removing a lock file while
/// another run waits on it would let a third take a new one), held until dropped. `shared`
/// runs may hold it together, an exclusive one alone; `wait`: block until it is free, else
/// None where another run holds it. A file system without locks gives a lock that holds
/// nothing (as [`FolderLocks`] commits without).
pub fn lock_file(path: &Path, shared: bool, wait: bool) -> Result<Option<std::fs::File>> {
    use std::os::fd::AsRawFd;
    use std::os::unix::fs::MetadataExt;
    let mode = if shared { libc::LOCK_SH } else { libc::LOCK_EX };
    let mode = if wait { mode } else { mode | libc::LOCK_NB };
    // A lock taken on a file that a failing run removed meanwhile (animate's RunLock) locks
    // nothing the next run sees: taken again on the file the path names now.
    for _ in 0..8 {
        // Read-only where it exists and may not be written (another user's, in a shared
        // folder): flock needs no write access.
        let f = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(path)
            .or_else(|e| match e.raw_os_error() {
                Some(libc::EACCES | libc::EPERM | libc::EROFS) => std::fs::File::open(path),
                _ => Err(e),
            })
            .with_context(|| format!("cannot open the lock file '{}'", path.display()))?;
        // SAFETY: flock on a descriptor `f` owns; closing it unlocks.
        let locked = loop {
            if unsafe { libc::flock(f.as_raw_fd(), mode) } == 0 {
                break true;
            }
            match std::io::Error::last_os_error().raw_os_error() {
                Some(libc::EINTR) => continue,
                Some(libc::EWOULDBLOCK) => return Ok(None),
                _ => break false,
            }
        };
        let same = match (f.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        };
        if same || !locked {
            return Ok(Some(f));
        }
    }
    bail!("the lock file '{}' keeps being replaced", path.display())
}

/// An exclusive lock (flock) on each target's folder while a set is committed, released
/// when dropped: two runs writing the same outputs at once committed file by file, both
/// with exit 0, and the set could end mixed (one run's EXR beside the other's PNG and JSON,
/// which `merge` would then weigh wrongly; an audit, 2026-12-06). Now the later commit waits
/// for the earlier one and replaces the whole set. Folders are told apart by device and
/// inode, so one folder reached by two paths is locked once (a second lock on it would wait
/// for the first forever), and taken in that order by every run. A folder still locked
/// after a minute (a writer stopped mid-commit), or that cannot be locked (a file system
/// without locks), is committed without.
pub struct FolderLocks {
    held: Vec<std::fs::File>,
}

/// Shared locks on the folders of `files` while they are read as sets (an image and its
/// report): a commit waits for the readers and they for it, so a reader never takes one
/// run's report and the next run's image. `merge` read a part a render was checkpointing
/// and refused it as split by a kill in 3 of 60 tries (an audit, 2026-12-07).
pub fn read_locks<'a>(files: impl Iterator<Item = &'a Path>) -> FolderLocks {
    FolderLocks::take(files, true)
}

impl FolderLocks {
    fn take<'a>(targets: impl Iterator<Item = &'a Path>, shared: bool) -> FolderLocks {
        use std::os::fd::AsRawFd;
        use std::os::unix::fs::MetadataExt;
        let mut dirs: Vec<((u64, u64), std::fs::File)> = targets
            .filter_map(|t| {
                let f = std::fs::File::open(folder_of(t)).ok()?;
                let m = f.metadata().ok()?;
                Some(((m.dev(), m.ino()), f))
            })
            .collect();
        dirs.sort_by_key(|(id, _)| *id);
        dirs.dedup_by_key(|(id, _)| *id);
        let mut held = Vec::new();
        for (_, f) in dirs {
            let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
            loop {
                // SAFETY: flock on a descriptor `f` owns; closing it unlocks.
                let mode = if shared { libc::LOCK_SH } else { libc::LOCK_EX };
                if unsafe { libc::flock(f.as_raw_fd(), mode | libc::LOCK_NB) } == 0 {
                    held.push(f);
                    break;
                }
                let busy =
                    std::io::Error::last_os_error().raw_os_error() == Some(libc::EWOULDBLOCK);
                if !busy || std::time::Instant::now() > deadline {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
        }
        FolderLocks { held }
    }

    /// Flushes each locked folder (the renames into it) once; best effort.
    fn sync(&self) {
        for f in &self.held {
            let _ = f.sync_all();
        }
    }
}

/// Files of one run written to temporaries one by one, then committed together
/// ([`commit_all`]); temporaries of a set that is dropped uncommitted are removed.
#[derive(Default)]
pub struct FileSet {
    files: Vec<(PathBuf, PathBuf)>,
}

impl FileSet {
    /// Lets `write` fill the temporary of `target`.
    pub fn add_with(
        &mut self,
        target: &Path,
        write: impl FnOnce(&Path) -> Result<()>,
    ) -> Result<()> {
        let tmp = write_temp(target, write)?;
        self.files.push((target.to_path_buf(), tmp));
        Ok(())
    }

    pub fn add(&mut self, target: &Path, bytes: &[u8]) -> Result<()> {
        self.add_with(target, |tmp| Ok(std::fs::write(tmp, bytes)?))
    }

    /// Moves every file into place together.
    pub fn commit(mut self) -> Result<()> {
        let files = std::mem::take(&mut self.files);
        commit_all(&files)
    }
}

impl Drop for FileSet {
    fn drop(&mut self) {
        for (_, tmp) in &self.files {
            let _ = std::fs::remove_file(tmp);
            untrack_temp(tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A commit waits while another holds its folder's lock, and then moves the file: without
    /// the lock the file is in place at once.
    #[test]
    fn a_commit_waits_for_the_folder_lock() {
        use std::os::fd::AsRawFd;
        let dir = tempfile::tempdir().unwrap();
        let (target, tmp) = (dir.path().join("a.exr"), dir.path().join(".a.exr.1.tmp"));
        std::fs::write(&tmp, b"new").unwrap();
        let held = std::fs::File::open(dir.path()).unwrap();
        // SAFETY: flock on a descriptor `held` owns.
        assert_eq!(unsafe { libc::flock(held.as_raw_fd(), libc::LOCK_EX) }, 0);
        let files = vec![(target.clone(), tmp)];
        let committing = std::thread::spawn(move || commit_all(&files));
        std::thread::sleep(std::time::Duration::from_millis(300));
        assert!(!target.exists(), "committed while the folder was locked");
        drop(held);
        committing.join().unwrap().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
    }

    /// A dead process's temporary of a target, untouched for an hour, goes; a fresh one, a
    /// live process's (pid 1, this one), a second name (.old), another target's and other
    /// files stay. Without the cleanup every name stays.
    #[test]
    fn stale_temporaries_of_dead_processes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let me = std::process::id();
        let hour_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
        let names = [
            (".a.exr.999999999.tmp", true),
            (".a.exr.999999998.tmp", false),
            (".a.exr.999999999.old", true),
            (".a.exr.1.tmp", true),
            (&format!(".a.exr.{me}.tmp"), true),
            (".b.exr.999999999.tmp", true),
            (".a.exr.x9.tmp", true),
            ("a.exr", true),
        ];
        for (n, old) in names {
            let f = std::fs::File::create(d.join(n)).unwrap();
            if old {
                f.set_modified(hour_ago).unwrap();
            }
        }
        remove_stale_temps(&d.join("a.exr"));
        let left: Vec<bool> = names.iter().map(|(n, _)| d.join(n).exists()).collect();
        assert_eq!(left, [false, true, true, true, true, true, true, true]);
    }
}
