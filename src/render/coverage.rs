//! Which rows of 8 pixels can see the scene at all, and the order the direct-light kernel
//! takes them in (`render.comp` main, `LiveRows`).
//!
//! A pixel whose every camera ray misses the scene adds exactly zero to its sums (there is
//! no background light), so leaving it out changes no bit of the image. On lavapipe such
//! pixels are not free: a SIMD group of 8 lanes runs every `if` body masked, so a group of
//! sky pixels still pays part of a sample (on city, 44 % of the rows at 96×72, they took
//! 13 % of the CPU time of `wang` at 128×96). The unit is the 8 pixels in a row that
//! render.comp's 8×8 workgroup gives one SIMD group; a row is kept when the frustum of its
//! pixels (every jittered ray lies inside it) meets the box of a BVH leaf. That test is
//! conservative: the frustum is widened by a 64th of a pixel and each box by `eps` on
//! every side, far beyond the rounding of the kernel's ray directions and of its triangle
//! test. [`dispatch_order`] then spreads the rows over lavapipe's threads.

use glam::DVec3;

use crate::accel::bvh::children;
use crate::accel::Bvh;
use crate::gpu::layout::{RenderParams, BVH_LEAF_BIT};

/// Pixels in a row that one entry stands for (the width of render.comp's 8×8 workgroup,
/// written there as `8u`).
pub const ROW_PIXELS: u32 = 8;
/// How far each frustum is widened on every side, in pixels.
const MARGIN_PIXELS: f64 = 1.0 / 64.0;

/// The rows of 8 pixels (`x / 8` in the low 16 bits, `y` in the high 16) of a
/// `params.width`×`params.height` film whose camera rays can meet a triangle of `bvh`, in the
/// order of the film's 8×8 blocks, and within a block by row, so that the 8 entries a
/// workgroup takes lie close together on the film (one block where all of it sees the
/// scene, two neighbours where rows were left out). `eps`: how far the boxes are widened
/// (the scene's ray epsilon).
pub fn live_rows(bvh: &Bvh, params: &RenderParams, eps: f32) -> Vec<u32> {
    let (w, h) = (params.width, params.height);
    let v = |a: [f32; 4]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let cam = Camera {
        pos: v(params.cam_pos),
        u: v(params.cam_u),
        v: v(params.cam_v),
        w: v(params.cam_w),
        width: w as f64,
        height: h as f64,
    };
    let mut search = Search {
        bvh,
        eps: eps.max(0.0) as f64,
        stack: Vec::new(),
        last: None,
    };
    rows_where(w, h, |x0, x1, y0, y1| {
        search.sees_scene(&cam.frustum(x0, x1, y0, y1))
    })
}

/// The rows of 8 pixels of a `width`×`height` film, block by block and within a block by
/// row, for which `sees(x0, x1, y0, y1)` holds of the pixels [x0, x1) × [y0, y1): asked of
/// each 8×8 block first, then of each row of a block where it held.
fn rows_where(
    width: u32,
    height: u32,
    mut sees: impl FnMut(u32, u32, u32, u32) -> bool,
) -> Vec<u32> {
    let mut rows = Vec::new();
    for by in 0..height.div_ceil(8) {
        for bx in 0..width.div_ceil(ROW_PIXELS) {
            let (x0, x1) = (bx * ROW_PIXELS, ((bx + 1) * ROW_PIXELS).min(width));
            let (y0, y1) = (by * 8, (by * 8 + 8).min(height));
            if !sees(x0, x1, y0, y1) {
                continue;
            }
            for y in y0..y1 {
                if sees(x0, x1, y, y + 1) {
                    rows.push(y << 16 | bx);
                }
            }
        }
    }
    rows
}

/// The order the dispatch takes `rows` in (those of [`live_rows`] or [`all_rows`]): their
/// workgroups of 8 rows in bit-reversed order, each workgroup's rows as they were.
///
/// lavapipe hands each of its threads one contiguous share of a dispatch's workgroups, not
/// the next one free, so a film whose cost is uneven from top to bottom kept one core idle
/// while the other finished: `wang`, city, direct light, 128×96, 1024 spp took 2.159 s in
/// the 2-D dispatch, 2.345 s over its rows that see the scene in block order (the sky rows
/// had been the cheap share of the top half) and 1.840 s over the same rows in this order,
/// with the same CPU time (docs/results.md, fifteenth session). Bit reversal puts
/// neighbouring workgroups, which cost about the same, in different shares for any number
/// of threads that is a power of two.
pub fn dispatch_order(rows: &[u32]) -> Vec<u32> {
    // Whole workgroups (8 consecutive entries) are reordered; a last one of fewer than 8
    // entries stays last, so that no other workgroup is cut short.
    let groups = rows.len() / 8;
    let n = groups.next_power_of_two();
    let bits = n.trailing_zeros();
    let mut out = Vec::with_capacity(rows.len());
    for i in 0..n {
        let g = if bits == 0 {
            i
        } else {
            i.reverse_bits() >> (usize::BITS - bits)
        };
        if g < groups {
            out.extend_from_slice(&rows[g * 8..g * 8 + 8]);
        }
    }
    out.extend_from_slice(&rows[groups * 8..]);
    out
}

/// Every row of 8 pixels of a `width`×`height` film in the order of [`live_rows`] (nothing
/// left out).
pub fn all_rows(width: u32, height: u32) -> Vec<u32> {
    rows_where(width, height, |_, _, _, _| true)
}

/// The camera as render.comp `camera_path` makes its rays: through (x + jx, y + jy) for
/// jitter in [0, 1)², direction w + ndc.x u + ndc.y v.
struct Camera {
    pos: DVec3,
    u: DVec3,
    v: DVec3,
    w: DVec3,
    width: f64,
    height: f64,
}

impl Camera {
    fn dir(&self, x: f64, y: f64) -> DVec3 {
        let nx = x / self.width * 2.0 - 1.0;
        let ny = 1.0 - y / self.height * 2.0;
        self.w + nx * self.u + ny * self.v
    }

    /// The inward normals of the planes through the camera that bound the rays through the
    /// pixels [x0, x1) × [y0, y1) (widened by MARGIN_PIXELS), and of the plane at the
    /// camera facing forward (every camera ray has a positive component along w).
    fn frustum(&self, x0: u32, x1: u32, y0: u32, y1: u32) -> Frustum {
        let m = MARGIN_PIXELS;
        let (x0, x1) = (x0 as f64 - m, x1 as f64 + m);
        let (y0, y1) = (y0 as f64 - m, y1 as f64 + m);
        let c = [
            self.dir(x0, y0),
            self.dir(x1, y0),
            self.dir(x1, y1),
            self.dir(x0, y1),
        ];
        let centre = self.dir(0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let mut normals = [self.w; 5];
        for i in 0..4 {
            let n = c[i].cross(c[(i + 1) % 4]);
            normals[i] = if n.dot(centre) < 0.0 { -n } else { n };
        }
        Frustum {
            pos: self.pos,
            normals,
        }
    }
}

struct Frustum {
    pos: DVec3,
    normals: [DVec3; 5],
}

impl Frustum {
    /// False only if the box [lo − eps, hi + eps] lies wholly outside one of the planes.
    fn meets(&self, lo: [f32; 3], hi: [f32; 3], eps: f64) -> bool {
        let lo = DVec3::new(lo[0] as f64, lo[1] as f64, lo[2] as f64) - eps - self.pos;
        let hi = DVec3::new(hi[0] as f64, hi[1] as f64, hi[2] as f64) + eps - self.pos;
        self.normals.iter().all(|n| {
            // The box's corner farthest along n.
            let q = DVec3::new(
                if n.x > 0.0 { hi.x } else { lo.x },
                if n.y > 0.0 { hi.y } else { lo.y },
                if n.z > 0.0 { hi.z } else { lo.z },
            );
            n.dot(q) >= 0.0
        })
    }
}

/// The search for a leaf a frustum meets, with its scratch stack and the box of the last
/// leaf it found: neighbouring rows mostly see the same leaf, so that box is tried first
/// (the same rows; the default scene, where every row sees the scene, 17.3 → 2.3 ms at
/// 640×480 and 114 → 11.7 ms at 1920×1080; docs/results.md, fifteenth session).
struct Search<'b> {
    bvh: &'b Bvh,
    eps: f64,
    stack: Vec<u32>,
    last: Option<([f32; 3], [f32; 3])>,
}

impl Search<'_> {
    /// Whether the frustum meets the box of a leaf with triangles (depth first, stopping at
    /// the first).
    fn sees_scene(&mut self, f: &Frustum) -> bool {
        if let Some((lo, hi)) = self.last {
            if f.meets(lo, hi, self.eps) {
                return true;
            }
        }
        if self.bvh.nodes.is_empty() {
            return false;
        }
        self.stack.clear();
        self.stack.push(0);
        while let Some(i) = self.stack.pop() {
            for (lo, hi, r, count) in children(&self.bvh.nodes[i as usize]) {
                let leaf = r & BVH_LEAF_BIT != 0;
                if leaf && count == 0 || !f.meets(lo, hi, self.eps) {
                    continue;
                }
                if leaf {
                    self.last = Some((lo, hi));
                    return true;
                }
                self.stack.push(r);
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn camera(width: u32, height: u32) -> RenderParams {
        // At the origin looking down −z, 90° vertical field of view.
        let c = crate::scene::Camera {
            position: Vec3::ZERO,
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            yfov: std::f32::consts::FRAC_PI_2,
        };
        crate::render::camera_vectors(&c, width, height)
    }

    /// A square facing the camera at z = −1 over x ∈ [x0, x0 + size], y ∈ [y0, y0 + size].
    fn square(x0: f32, y0: f32, size: f32) -> Vec<[Vec3; 3]> {
        let (a, b) = (x0, x0 + size);
        let (c, d) = (y0, y0 + size);
        vec![
            [
                Vec3::new(a, c, -1.0),
                Vec3::new(b, c, -1.0),
                Vec3::new(b, d, -1.0),
            ],
            [
                Vec3::new(a, c, -1.0),
                Vec3::new(b, d, -1.0),
                Vec3::new(a, d, -1.0),
            ],
        ]
    }

    fn decoded(rows: &[u32]) -> Vec<(u32, u32)> {
        rows.iter().map(|r| (r >> 16, r & 0xffff)).collect()
    }

    #[test]
    fn rows_that_see_a_square_are_kept_and_the_others_left_out() {
        // 64×64 pixels over x, y ∈ [−1, 1] at z = −1: a pixel is 1/32 wide, column c spans
        // x ∈ [(c − 32)/32, (c − 31)/32], row r spans y ∈ [1 − (r + 1)/32, 1 − r/32]. The
        // square x, y ∈ [0.01, 0.24] lies in columns 32–39 (block 4) and rows 24–31.
        let p = camera(64, 64);
        let rows = live_rows(&Bvh::build(&square(0.01, 0.01, 0.23)), &p, 0.0);
        assert_eq!(decoded(&rows), (24..32).map(|y| (y, 4)).collect::<Vec<_>>());
        // x ∈ [0.22, 0.28], y ∈ [−0.02, 0.04]: columns 39–40 and rows 30–32, across the
        // corner of four 8×8 blocks: each block's rows that it reaches, block by block.
        let rows = live_rows(&Bvh::build(&square(0.22, -0.02, 0.06)), &p, 0.0);
        assert_eq!(
            decoded(&rows),
            vec![(30, 4), (31, 4), (30, 5), (31, 5), (32, 4), (32, 5)]
        );
    }

    #[test]
    fn a_box_behind_the_camera_is_not_seen_and_a_wide_margin_keeps_more() {
        let p = camera(16, 16);
        let mut behind = square(-0.1, -0.1, 0.2);
        for t in &mut behind {
            for v in t.iter_mut() {
                v.z = 1.0;
            }
        }
        assert!(live_rows(&Bvh::build(&behind), &p, 0.0).is_empty());
        // A square just right of the image (x from 1.01 at z = −1: outside the frustum by
        // 0.01) is left out with no slack and kept with eps = 0.1.
        let off = square(1.01, 0.0, 0.25);
        assert!(live_rows(&Bvh::build(&off), &p, 0.0).is_empty());
        assert!(!live_rows(&Bvh::build(&off), &p, 0.1).is_empty());
    }

    #[test]
    fn the_dispatch_order_interleaves_whole_workgroups() {
        // 5 whole workgroups of 8 rows and one of 3: bit reversal over 8 gives 0, 4, 2, 6,
        // 1, 5, 3, 7, of which 0, 4, 2, 1, 3 exist; the partial one stays last.
        let rows: Vec<u32> = (0..43).collect();
        let order = dispatch_order(&rows);
        let starts: Vec<u32> = order.chunks(8).map(|c| c[0]).collect();
        assert_eq!(starts, vec![0, 32, 16, 8, 24, 40]);
        assert!(order
            .chunks(8)
            .all(|c| c.windows(2).all(|w| w[1] == w[0] + 1)));
        let mut sorted = order.clone();
        sorted.sort();
        assert_eq!(sorted, rows);
        assert_eq!(dispatch_order(&[]), Vec::<u32>::new());
        assert_eq!(dispatch_order(&[7, 9]), vec![7, 9]);
    }

    #[test]
    fn all_rows_follow_the_blocks_of_the_dispatch() {
        // 12×10: blocks of 8×8, the last ones partial; within a block rows in order.
        let rows = all_rows(12, 10);
        let first: Vec<(u32, u32)> = rows[..10].iter().map(|r| (r >> 16, r & 0xffff)).collect();
        assert_eq!(
            first,
            vec![
                (0, 0),
                (1, 0),
                (2, 0),
                (3, 0),
                (4, 0),
                (5, 0),
                (6, 0),
                (7, 0),
                (0, 1),
                (1, 1)
            ]
        );
        assert_eq!(rows.len(), 10 * 2);
    }
}
