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
