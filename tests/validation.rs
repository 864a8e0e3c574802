//! The validation layer is really on in tests: a dispatch with an unwritten descriptor set
//! must come back as an error (otherwise "no validation errors" in other tests means nothing).

mod common;

use lightlearn::gpu::layout::TraceParams;
use lightlearn::gpu::{kernels, ComputePipeline};

#[test]
fn validation_errors_fail_the_submission() {
    let ctx = common::ctx();
    let p = ComputePipeline::new(
        &ctx,
        "trace",
        kernels::TRACE,
        4,
        std::mem::size_of::<TraceParams>() as u32,
        &[],
    )
    .unwrap();
    // No bind(): the descriptor set is used without ever being written.
    let params = TraceParams::default();
    let result = ctx.submit(|cmd| p.dispatch(cmd, bytemuck::bytes_of(&params), [1, 1, 1]));
    let err = result.expect_err("the validation layer must report the unwritten descriptor set");
    assert!(err.to_string().contains("validation"), "{err}");
}

/// An object never destroyed is reported by the layer when the device is destroyed; that
/// report went into a log nobody read, so leaks passed every test and `--validation`. Now
/// the context's end says it (a panic: Drop cannot return an error).
#[test]
fn objects_left_at_the_end_fail_validation() {
    let ctx = common::ctx();
    let info = ash::vk::BufferCreateInfo::default()
        .size(64)
        .usage(ash::vk::BufferUsageFlags::STORAGE_BUFFER);
    // Made and never destroyed.
    let _leaked = unsafe { ctx.device.create_buffer(&info, None) }.unwrap();
    let ended = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || drop(ctx)));
    let why = ended.expect_err("the leaked buffer must be reported");
    let msg = why.downcast_ref::<String>().cloned().unwrap_or_default();
    assert!(
        msg.contains("validation errors while the context was destroyed"),
        "{msg}"
    );
    // A context that destroys what it made ends quietly.
    drop(common::ctx());
}
