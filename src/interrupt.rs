//! Ctrl-C: the command line asks for a stop ([`request`]); the pass loop finishes the batch
//! it is in, stops, and says so in its result, so the samples taken so far are written
//! instead of lost. The library installs no handler itself (`main.rs` does).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks every running render to stop after its current batch.
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// How many [`Active`] guards live (they nest: `render --checkpoint` holds one across its
/// pass loops and the checkpoints' writes between them, each pass loop one more).
static ACTIVE: AtomicUsize = AtomicUsize::new(0);

/// Marks a pass loop as running while the guard lives, or a command's span that must not
/// be cut (its renders and the writes after them: `render --checkpoint`, `compare`,
/// `reference`): only then can a stop be honoured after the current batch or write
/// (elsewhere a Ctrl-C should end the program at once).
pub struct Active;

impl Active {
    pub fn begin() -> Active {
        ACTIVE.fetch_add(1, Ordering::SeqCst);
        Active
    }
}

impl Drop for Active {
    fn drop(&mut self) {
        ACTIVE.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Whether a pass loop is running.
pub fn active() -> bool {
    ACTIVE.load(Ordering::SeqCst) > 0
}

/// Whether a stop was asked for.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// How many [`Writing`] guards live, and whether a quick exit waits for them.
static WRITING: AtomicUsize = AtomicUsize::new(0);
static DEFERRED: AtomicBool = AtomicBool::new(false);

/// Marks a rename or a commit of outputs in progress, which a quick exit (a Ctrl-C outside a
/// render, or a second one) must not cut: such an exit waits for the guard's end
/// ([`defer_exit`]), then ends the process as it would have (status 130); a guard begun
/// after such an exit was asked ends the process at once, before its renames. Unlike
/// [`Active`], it never turns the stop into "finish the batch" (a review, 2026-12-07).
/// Every guard lives on the main thread (a guard begun on another thread while one is in a
/// commit would end the process between that commit's renames).
pub struct Writing;

impl Writing {
    pub fn begin() -> Writing {
        WRITING.fetch_add(1, Ordering::SeqCst);
        // An exit already under way (its handler saw no guard and is removing the
        // temporaries) must not be raced by renames: exit here, before any (a review,
        // 2026-12-07).
        if DEFERRED.load(Ordering::SeqCst) {
            quick_exit();
        }
        Writing
    }
}

impl Drop for Writing {
    fn drop(&mut self) {
        if WRITING.fetch_sub(1, Ordering::SeqCst) == 1 && DEFERRED.load(Ordering::SeqCst) {
            quick_exit();
        }
    }
}

/// For a signal handler about to end the process at once: where a [`Writing`] guard lives,
/// the exit is left to it (true); else false, and the handler ends the process itself.
pub fn defer_exit() -> bool {
    // The flag first: a guard that begins or ends after it sees it and exits itself; one
    // that ended before leaves the count at 0 here, and the handler exits. Both exiting is
    // harmless (the first `_exit` wins).
    DEFERRED.store(true, Ordering::SeqCst);
    WRITING.load(Ordering::SeqCst) > 0
}

/// Ends the process at once with status 130, removing the temporaries being written and the
/// empty folders of the command first (crate::io::remove_pending). `_exit`, not `exit`:
/// exit's handlers (the Vulkan driver's among them) would run while another thread is
/// still inside the driver (a review, 2026-12-06).
pub fn quick_exit() -> ! {
    crate::io::remove_pending();
    // SAFETY: _exit ends the process at once; it touches no Rust state.
    unsafe { libc::_exit(130) }
}
