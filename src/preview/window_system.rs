//! Which window system the preview opens: Wayland where WAYLAND_DISPLAY names a running
//! compositor, else X11. winit takes Wayland whenever the variable is set and gives up if no
//! compositor answers, and it can make only one event loop a process, so the choice is made
//! before: a WAYLAND_DISPLAY left from another session (tmux reattached over X) ended the
//! preview although X11 worked (an audit, 2026-12-07), where Blender falls back to X11.

use std::path::PathBuf;

use anyhow::{anyhow, Result};
use winit::event_loop::EventLoop;

/// The event loop, and a warning when a stale WAYLAND_DISPLAY was passed over for X11.
pub fn event_loop(no_display: &str) -> Result<(EventLoop<()>, Option<String>)> {
    let mut builder = EventLoop::builder();
    let mut note = None;
    if let Some(socket) = stale_wayland_socket() {
        if std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) {
            use winit::platform::x11::EventLoopBuilderExtX11;
            builder.with_x11();
            note = Some(format!(
                "WAYLAND_DISPLAY names '{}', where no Wayland compositor answers; using the X11 display '{}' instead (unset WAYLAND_DISPLAY to silence this)",
                socket.display(),
                std::env::var("DISPLAY").unwrap_or_default()
            ));
        }
    }
    let event_loop = builder
        .build()
        .map_err(|e| anyhow!("{no_display} ({})", os_message(&e.to_string())))?;
    Ok((event_loop, note))
}

/// The socket WAYLAND_DISPLAY names, where nothing accepts a connection (None where the
/// variable is unset or empty, WAYLAND_SOCKET hands over a connection, or a compositor
/// answers).
fn stale_wayland_socket() -> Option<PathBuf> {
    if std::env::var_os("WAYLAND_SOCKET").is_some_and(|s| !s.is_empty()) {
        return None;
    }
    let name = std::env::var_os("WAYLAND_DISPLAY").filter(|d| !d.is_empty())?;
    // libwayland's rule: an absolute name is the socket, else it is in XDG_RUNTIME_DIR.
    let socket = match PathBuf::from(&name) {
        p if p.is_absolute() => p,
        p => PathBuf::from(std::env::var_os("XDG_RUNTIME_DIR").unwrap_or_default()).join(p),
    };
    match std::os::unix::net::UnixStream::connect(&socket) {
        Ok(_) => None,
        Err(_) => Some(socket),
    }
}

/// winit's error text without its source location ("os error at
/// /root/.cargo/registry/…/mod.rs:89: Could not find wayland compositor" → the reason).
fn os_message(e: &str) -> String {
    match e.strip_prefix("os error at ") {
        Some(rest) => match rest.find(": ") {
            Some(i) => rest[i + 2..].to_string(),
            None => rest.to_string(),
        },
        None => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn os_messages_lose_their_source_location() {
        assert_eq!(
            super::os_message(
                "os error at /root/.cargo/registry/src/x/winit-0.30.13/src/a.rs:89: Could not find wayland compositor"
            ),
            "Could not find wayland compositor"
        );
        assert_eq!(super::os_message("plain"), "plain");
    }
}
