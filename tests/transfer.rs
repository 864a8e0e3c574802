//! Batched transfers (src/gpu/transfer.rs): uploads and clears recorded together land where
//! each was aimed, in the order recorded, before the dispatches recorded after them; several
//! buffers read back in one submission come back whole and apart.

mod common;

use lightlearn::gpu::transfer::read_many;
use lightlearn::gpu::{Buffer, Transfers};

#[test]
fn batched_uploads_clears_and_reads_land_where_aimed() {
    let ctx = common::ctx();
    let a = Buffer::from_slice(&ctx, "a", &[7u32; 16]).unwrap();
    let b = Buffer::from_slice(&ctx, "b", &[9u32; 8]).unwrap();
    let c = Buffer::words_unfilled(&ctx, "c", 5).unwrap();
    let mut up = Transfers::new();
    // Unaligned piece lengths, so each piece's staging offset differs from its length sum.
    up.write(&a, 4, bytemuck::cast_slice(&[1u32, 2, 3]));
    up.clear(&b);
    up.write(&a, 40, bytemuck::cast_slice(&[4u32]));
    up.write(&c, 0, bytemuck::cast_slice(&[10u32, 11, 12, 13, 14]));
    // A later write to the same bytes wins (the order recorded).
    up.write(&a, 8, bytemuck::cast_slice(&[5u32]));
    assert!(!up.is_empty());
    up.submit(&ctx, |_| {}).unwrap();
    let got = read_many(&ctx, &[(&a, 64), (&b, 32), (&c, 20), (&a, 8)]).unwrap();
    let words = |v: &Vec<u8>| -> Vec<u32> {
        v.chunks_exact(4)
            .map(bytemuck::pod_read_unaligned)
            .collect()
    };
    let mut want_a = [7u32; 16];
    want_a[1..4].copy_from_slice(&[1, 5, 3]);
    want_a[10] = 4;
    assert_eq!(words(&got[0]), want_a);
    assert_eq!(words(&got[1]), [0u32; 8]);
    assert_eq!(words(&got[2]), [10, 11, 12, 13, 14]);
    assert_eq!(words(&got[3]), want_a[..2]);
}
