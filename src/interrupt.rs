//! Ctrl-C: the command line asks for a stop ([`request`]); the pass loop finishes the batch
//! it is in, stops, and says so in its result, so the samples taken so far are written
//! instead of lost. The library installs no handler itself (`main.rs` does).

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks every running render to stop after its current batch.
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Whether a stop was asked for.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}
