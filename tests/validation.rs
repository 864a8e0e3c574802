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

/// The loader's own errors (a driver file that does not open, as a container's
/// nvidia_icd.json without the driver) are no validation errors: with the messenger chained
/// into the instance's creation they failed every `--validation` run (a review,
/// 2026-12-07).
#[test]
fn a_missing_driver_file_is_no_validation_error() {
    let lvp = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";
    let drivers = std::env::var("VK_DRIVER_FILES").unwrap_or_else(|_| lvp.into());
    let dir = tempfile::tempdir().unwrap();
    let o = common::run_in(
        &[
            "render",
            "--validation",
            "--width",
            "8",
            "--height",
            "6",
            "--spp",
            "1",
            "--out",
            "r.exr",
            "-q",
        ],
        dir.path(),
        &[(
            "VK_DRIVER_FILES",
            &format!("{drivers}:/nonexistent/x_icd.json"),
        )],
    );
    assert!(o.status.success(), "{}", common::stderr(&o));
}
