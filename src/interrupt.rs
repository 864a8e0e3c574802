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
