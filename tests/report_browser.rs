//! The compare report in a real browser: headless Chromium loads index.html; every image
//! decodes, the metrics tables have their rows, the convergence plot has a line per sampler,
//! and a screenshot of the page is not blank. Skipped, with a message, without Chromium
//! (ci/setup.sh installs Debian's `chromium`).

mod common;

use std::path::Path;
use std::process::Command;

fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|c| {
            Command::new(c)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

fn headless(browser: &str, profile: &Path, extra: &[&str], page: &Path) -> std::process::Output {
    Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("run chromium")
}

#[test]
fn report_renders_in_a_browser() {
    let Some(browser) = chromium() else {
        eprintln!(
            "skipping: Chromium not found (ci/setup.sh installs the Debian package `chromium`)"
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let o = Command::new(common::exe())
        .arg("compare")
        .arg(&scene)
        .args([
            "--samplers",
            "uniform,power",
            "--time",
            "0.3",
            "--spp",
            "4",
            "--reference-spp",
            "32",
        ])
        .args(["--width", "64", "--height", "48", "-q", "--out"])
        .arg(&out)
        .env("LIGHTLEARN_CACHE", dir.path().join("cache"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let page = out.join("index.html");

    // The DOM after the page's scripts ran and its images loaded.
    let dom = headless(browser, &dir.path().join("p1"), &["--dump-dom"], &page);
    let dom = String::from_utf8_lossy(&dom.stdout).into_owned();
    assert!(
        dom.contains("data-ready=\"1\""),
        "the page's load handler did not run"
    );
    let attr = |name: &str| -> usize {
        let i = dom
            .find(&format!("{name}=\""))
            .unwrap_or_else(|| panic!("no {name}"))
            + name.len()
            + 2;
        dom[i..].split('"').next().unwrap().parse().unwrap()
    };
    let (loaded, total) = (attr("data-images-loaded"), attr("data-images-total"));
    // Per comparison: reference + 2 images, 2 error maps, 2 zero-sample maps, 2 flip images.
    assert_eq!(total, 2 * 9, "images on the page");
    assert_eq!(loaded, total, "every image decoded");
    assert_eq!(dom.matches("<table class=\"metrics\">").count(), 2);
    assert_eq!(
        dom.matches("<tr>").count(),
        2 * 3,
        "header + one row per sampler, twice"
    );
    let series = dom.matches("class=\"series\"").count();
    assert_eq!(series, 4, "one plot line per sampler and comparison");
    assert!(!dom.contains("points=\"\""), "every plot line has points");

    // A screenshot: the page is drawn, not blank.
    let shot = dir.path().join("shot.png");
    let o = headless(
        browser,
        &dir.path().join("p2"),
        &[
            "--window-size=1200,1600",
            &format!("--screenshot={}", shot.display()),
        ],
        &page,
    );
    assert!(
        shot.exists(),
        "no screenshot: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let ch = info.color_type.samples();
    let px: Vec<&[u8]> = buf[..info.buffer_size()].chunks(ch).collect();
    let non_white = px
        .iter()
        .filter(|p| p[..3].iter().any(|&c| c < 240))
        .count();
    let colours: std::collections::HashSet<[u8; 3]> = px
        .iter()
        .map(|p| [p[0] >> 3, p[1] >> 3, p[2] >> 3])
        .collect();
    assert!(
        non_white * 10 > px.len(),
        "screenshot mostly blank ({non_white} of {} px drawn)",
        px.len()
    );
    assert!(
        colours.len() > 200,
        "screenshot has only {} colours: images missing?",
        colours.len()
    );
}
