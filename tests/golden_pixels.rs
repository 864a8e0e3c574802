//! The pixels of small renders of every committed scene with every sampler, direct light
//! and path traced, against a table of their MD5 sums (tests/golden_pixels.txt): a change
//! that should not change any image (a refactor) must keep every one. A change that does
//! (a new default, a kernel fix) regenerates the table with `LIGHTLEARN_BLESS=1 cargo test
//! --release --test golden_pixels` and says so in its commit. The table holds for lavapipe
//! (llvmpipe) only; on other devices the test says it is skipped.

mod common;

use std::fmt::Write as _;
use std::path::Path;

use lightlearn::accel::Bvh;
use lightlearn::render::{self, Budget, GpuScene, LightSampler, RenderSettings};
use lightlearn::scene::gltf_load;

const SCENES: &[&str] = &[
    "city",
    "cornell",
    "cornell-glossy",
    "default",
    "hall",
    "rooms",
    "rooms16",
    "rooms16-glossy",
    "strings",
];

/// MD5 of the pixels as little-endian f32 RGB, row by row (what `md5(pixels.tobytes())` of
/// the EXR read with numpy gives).
fn md5_hex(bytes: &[u8]) -> String {
    // A small MD5 (RFC 1321): the dev-dependencies have none, and this is 40 lines.
    let s: [u32; 64] = [
        7, 12, 17, 22, 7, 12, 17, 22, 7, 12, 17, 22, 7, 12, 17, 22, 5, 9, 14, 20, 5, 9, 14, 20, 5,
        9, 14, 20, 5, 9, 14, 20, 4, 11, 16, 23, 4, 11, 16, 23, 4, 11, 16, 23, 4, 11, 16, 23, 6, 10,
        15, 21, 6, 10, 15, 21, 6, 10, 15, 21, 6, 10, 15, 21,
    ];
    let k: Vec<u32> = (0..64)
        .map(|i| ((i as f64 + 1.0).sin().abs() * 4294967296.0) as u32)
        .collect();
    let mut msg = bytes.to_vec();
    let bits = (bytes.len() as u64).wrapping_mul(8);
    msg.push(0x80);
    while msg.len() % 64 != 56 {
        msg.push(0);
    }
    msg.extend_from_slice(&bits.to_le_bytes());
    let mut h = [0x67452301u32, 0xefcdab89, 0x98badcfe, 0x10325476];
    for chunk in msg.chunks(64) {
        let m: Vec<u32> = chunk
            .chunks(4)
            .map(|w| u32::from_le_bytes(w.try_into().unwrap()))
            .collect();
        let [mut a, mut b, mut c, mut d] = h;
        for i in 0..64 {
            let (f, g) = match i / 16 {
                0 => ((b & c) | (!b & d), i),
                1 => ((d & b) | (!d & c), (5 * i + 1) % 16),
                2 => (b ^ c ^ d, (3 * i + 5) % 16),
                _ => (c ^ (b | !d), (7 * i) % 16),
            };
            let f = f.wrapping_add(a).wrapping_add(k[i]).wrapping_add(m[g]);
            a = d;
            d = c;
            c = b;
            b = b.wrapping_add(f.rotate_left(s[i]));
        }
        for (x, y) in h.iter_mut().zip([a, b, c, d]) {
            *x = x.wrapping_add(y);
        }
    }
    h.iter()
        .flat_map(|x| x.to_le_bytes())
        .fold(String::new(), |mut out, b| {
            let _ = write!(out, "{b:02x}");
            out
        })
}

#[test]
fn md5_matches_the_rfc_examples() {
    assert_eq!(md5_hex(b""), "d41d8cd98f00b204e9800998ecf8427e");
    assert_eq!(
        md5_hex(b"The quick brown fox jumps over the lazy dog"),
        "9e107d9d372bb6826bd81d3542a419d6"
    );
}

#[test]
fn small_renders_keep_their_pixels() {
    let ctx = common::ctx();
    if !ctx.describe().contains("llvmpipe") {
        eprintln!(
            "skipped: the table is for lavapipe, this device is {}",
            ctx.describe()
        );
        return;
    }
    let mut table = String::new();
    for name in SCENES {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(format!("{name}.glb"));
        let scene = gltf_load::load(&path, &mut |_| {}).unwrap();
        let gpu = GpuScene::upload(&ctx, &scene, &Bvh::build(&scene.triangles)).unwrap();
        for sampler in LightSampler::ALL {
            for depth in [1, 3] {
                let settings = RenderSettings {
                    width: 24,
                    height: 16,
                    budget: Budget::Samples(4),
                    seed: 0,
                    sampler,
                    regions: Default::default(),
                    learn: Default::default(),
                    resume: None,
                    stratify: lightlearn::render::Stratify::Sobol,
                    max_depth: depth,
                    light_point: Default::default(),
                    indirect_light_samples: 1,
                    first_light_samples: 1,
                };
                let r = render::render(&ctx, &scene, &gpu, &settings, &mut |_, _| {}).unwrap();
                let px: Vec<f32> = r.mean().into_iter().flatten().collect();
                let sum = md5_hex(bytemuck::cast_slice(&px));
                writeln!(table, "{name}-{}-{depth} {sum}", sampler.name()).unwrap();
            }
        }
    }
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden_pixels.txt");
    if std::env::var_os("LIGHTLEARN_BLESS").is_some() {
        std::fs::write(&file, &table).unwrap();
        eprintln!("wrote {}", file.display());
        return;
    }
    let want = std::fs::read_to_string(&file).expect("tests/golden_pixels.txt");
    let changed: Vec<String> = want
        .lines()
        .zip(table.lines())
        .filter(|(a, b)| a != b)
        .map(|(a, _)| a.split(' ').next().unwrap_or("").to_string())
        .collect();
    assert!(
        changed.is_empty() && want.lines().count() == table.lines().count(),
        "{} of {} renders changed their pixels: {changed:?} (regenerate with LIGHTLEARN_BLESS=1 if intended)",
        changed.len(),
        table.lines().count()
    );
}
