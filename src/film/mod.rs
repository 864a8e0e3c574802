//! Images out: float32 RGB EXR (the result), tone-mapped sRGB PNG (for a quick look) and a
//! JSON report. All three are written to temporary files first and renamed into place
//! together, so a failure never leaves a half-written output.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};

/// The output paths derived from `--out FILE.exr`.
#[derive(Clone, Debug)]
pub struct OutputPaths {
    pub exr: PathBuf,
    pub png: PathBuf,
    pub json: PathBuf,
}

impl OutputPaths {
    /// Checks the name and that all three files can be written, before any rendering work
    /// is done.
    pub fn new(exr: &Path) -> Result<OutputPaths> {
        // ".exr" alone is a name without an extension to Path (a dot file): say what is
        // missing rather than that it does not end in .exr.
        let name = exr.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.eq_ignore_ascii_case(".exr") {
            bail!(
                "--out '{}' has no name before .exr: name the image, e.g. render.exr",
                exr.display()
            );
        }
        if exr
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_lowercase)
            != Some("exr".into())
        {
            bail!(
                "--out '{}' must end in .exr (the PNG and JSON are written next to it)",
                exr.display()
            );
        }
        let paths = OutputPaths {
            exr: exr.to_path_buf(),
            png: exr.with_extension("png"),
            json: exr.with_extension("json"),
        };
        for p in paths.all() {
            crate::io::check_writable(p)?;
        }
        Ok(paths)
    }

    /// The PNG and the JSON are named after the EXR, not by the user: one that exists and
    /// is not a lightlearn output is a user's file (`--out notes.exr` replaced notes.json
    /// with a report, exit 0; an audit, 2026-12-06). A JSON is ours when it is a lightlearn
    /// report; a PNG when such a report or the EXR is beside it (the three are written
    /// together, the JSON last: a run killed between the renames, or a report removed by
    /// hand, leaves the two images). Called by the commands after their checks against
    /// their inputs, whose messages say more (which input the output would replace).
    pub fn check_not_foreign(&self) -> Result<()> {
        let ours = is_report(&self.json);
        let foreign = if self.json.is_file() && !ours {
            Some((&self.json, "is not a lightlearn report"))
        } else if self.png.is_file() && !ours && !self.exr.is_file() {
            Some((&self.png, "has no lightlearn EXR or report beside it"))
        } else {
            None
        };
        if let Some((p, why)) = foreign {
            bail!(
                "'{}' exists and {why}: --out '{}' would replace it with the render's {}; name another --out, move the file, or add --force (render) to replace it",
                p.display(),
                self.exr.display(),
                if *p == self.json { "report" } else { "preview" }
            );
        }
        Ok(())
    }

    pub fn all(&self) -> [&Path; 3] {
        [&self.exr, &self.png, &self.json]
    }
}

/// Whether `p` is a report lightlearn wrote (a JSON object naming its EXR's checksum, its
/// version or its merged parts). Past 64 MiB, more than any report, it is cut short and so
/// not one.
pub(crate) fn is_report(p: &Path) -> bool {
    let Ok(bytes) = crate::io::read_regular(p, 64 << 20) else {
        return false;
    };
    serde_json::from_slice::<serde_json::Value>(&bytes).is_ok_and(|v| {
        [EXR_CHECKSUM, "lightlearn_version", "merged_from"]
            .iter()
            .any(|k| v.get(k).is_some())
    })
}

/// Writes EXR, PNG and JSON together ([`crate::io::commit_all`]: all three or the old set;
/// only a kill between their renames can split them, which [`check_report`] then tells).
pub fn write_outputs(
    paths: &OutputPaths,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    report: &serde_json::Value,
) -> Result<()> {
    write_outputs_with(paths, width, height, rgb, report, &[], 1.0)
}

/// [`write_outputs`] with more files of the same run (`--save-stats`) and the PNG's pixels ×
/// `png_exposure` (`--exposure`; the report says the factor where it is not 1, the EXR
/// holds the radiance either way): every file is written to a temporary first and all are
/// moved into place together ([`crate::io::commit_all`]).
pub fn write_outputs_with(
    paths: &OutputPaths,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    report: &serde_json::Value,
    extra: &[(&Path, &[u8])],
    png_exposure: f32,
) -> Result<()> {
    if png_exposure == 1.0 {
        return write_all(paths, width, height, rgb, report, extra, 1.0);
    }
    let mut report = report.clone();
    report["png_exposure"] = serde_json::json!(png_exposure);
    write_all(paths, width, height, rgb, &report, extra, png_exposure)
}

/// [`write_outputs`] with the PNG scaled by `exposure` (the preview's, so that P saves the
/// picture on screen: it saved the unexposed one, an audit, 2026-12-07); the EXR holds the
/// radiance as always, and the report says the PNG's exposure.
pub fn write_outputs_exposed(
    paths: &OutputPaths,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    report: &serde_json::Value,
    exposure: f32,
) -> Result<()> {
    let mut report = report.clone();
    report["png_exposure"] = serde_json::json!(exposure);
    write_all(paths, width, height, rgb, &report, &[], exposure)
}

/// `--exposure EV` (render, animate): the PNG's factor 2^EV; −20 to 20 stops (the preview's
/// range), finite.
pub fn exposure_factor(ev: f32) -> Result<f32> {
    if !(ev.is_finite() && (-20.0..=20.0).contains(&ev)) {
        anyhow::bail!(
            "--exposure {ev} is out of range: give stops from -20 to 20 (0: as rendered)"
        );
    }
    Ok(2f32.powf(ev))
}

fn write_all(
    paths: &OutputPaths,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    report: &serde_json::Value,
    extra: &[(&Path, &[u8])],
    png_exposure: f32,
) -> Result<()> {
    let result = (|| -> Result<()> {
        let mut set = crate::io::FileSet::default();
        let mut sum = String::new();
        set.add_with(&paths.exr, |tmp| {
            write_exr(tmp, width, height, rgb)?;
            sum = exr_checksum(tmp)?;
            Ok(())
        })?;
        set.add_with(&paths.png, |tmp| {
            if png_exposure == 1.0 {
                write_png(tmp, width, height, rgb)
            } else {
                let exposed: Vec<[f32; 3]> =
                    rgb.iter().map(|p| p.map(|c| c * png_exposure)).collect();
                write_png(tmp, width, height, &exposed)
            }
        })?;
        let mut report = report.clone();
        report[EXR_CHECKSUM] = serde_json::json!(sum);
        set.add(
            &paths.json,
            (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
        )?;
        for (p, bytes) in extra {
            set.add(p, bytes)?;
        }
        set.commit()
    })();
    result.with_context(|| format!("cannot write the render to '{}'", paths.exr.display()))
}

/// The report's field that holds its EXR's checksum ([`exr_checksum`]): every report that
/// [`write_outputs`] writes names the bytes of the EXR written with it, so a reader can tell
/// a pair that was split apart ([`check_report`]).
pub const EXR_CHECKSUM: &str = "exr_fnv1a";

/// FNV-1a (64 bit, as 16 hex digits) of the file at `path`, streamed (an EXR of the
/// largest film is 3 GB). Regular files only: a FIFO would block the open, a link to
/// /dev/zero would never end.
pub fn exr_checksum(path: &Path) -> Result<String> {
    let mut hash = crate::fnv::Fnv1a::default();
    crate::io::open_regular(path)
        .and_then(|(f, _)| {
            std::io::copy(
                &mut std::io::BufReader::with_capacity(1 << 20, f),
                &mut hash,
            )
        })
        .map_err(|e| anyhow!("cannot read EXR '{}': {e}", path.display()))?;
    Ok(format!("{:016x}", hash.0))
}

/// Checks that `exr` is the image that `report` (read from `json`, the report beside it)
/// was written with. The EXR, PNG and JSON of a render are renamed into place one after
/// the other: a render killed between the renames (or a file copied over one of the pair)
/// left an EXR beside another render's report, which `merge` weighed by the wrong sample
/// count and `compare` took the wrong noise from, silently. Reports written before the
/// checksum existed have none and pass.
pub fn check_report(exr: &Path, json: &Path, report: &serde_json::Value) -> Result<()> {
    let Some(want) = report[EXR_CHECKSUM].as_str() else {
        return Ok(());
    };
    let got = exr_checksum(exr)?;
    if got != want {
        bail!(
            "'{}' is not the image its report '{}' describes (checksum {got}, the report's {want}): the pair was split apart (a render killed while it renamed them, whose own report may wait beside them as a hidden .NAME.json.PID.tmp, or a file copied over one); use the matching report or render it again",
            exr.display(),
            json.display()
        );
    }
    Ok(())
}

/// Float32 RGB OpenEXR. Written with one thread, so the same pixels give the same bytes
/// (with the crate's parallel writer, four runs of one command gave four files: the chunks
/// came out in a different order, 0 pixels differing).
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<()> {
    use exr::prelude::*;
    let w = width as usize;
    // An image of another size (a library caller's, after a resize) panicked mid-write (an
    // audit, 2026-12-07).
    if rgb.len() != w * height as usize {
        anyhow::bail!(
            "cannot write '{}': the image has {} pixels, not {width}×{height}",
            path.display(),
            rgb.len()
        );
    }
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = rgb[y * w + x];
        (p[0], p[1], p[2])
    });
    Image::from_channels((w, height as usize), channels)
        .write()
        .non_parallel()
        .to_file(path)
        .map_err(|e| match e {
            // Kept as an io::Error, so the caller can say what to do (a full disk).
            exr::error::Error::Io(io) => anyhow::Error::new(io).context("EXR write failed"),
            e => anyhow!("EXR write failed: {e}"),
        })
}

/// The largest side of an EXR that [`read_exr`] reads: the largest film (16384).
const MAX_EXR_SIDE: usize = 16384;

/// Reads a float RGB EXR written by [`write_exr`] (tests, `compare`).
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    use exr::prelude::*;
    use std::io::{Seek, SeekFrom};
    let fail = |e: &dyn std::fmt::Display| anyhow!("cannot read EXR '{}': {e}", path.display());
    // One open of a regular file (a FIFO would block the reader) for the header and the
    // pixels. The header first: its size decides the allocation below (a 1-KB file that
    // claimed 100000×100000 asked for 120 GB and aborted `merge` and `compare`).
    let (file, _) = crate::io::open_regular(path).map_err(|e| fail(&e))?;
    let mut reader = std::io::BufReader::new(file);
    let meta = exr::meta::MetaData::read_from_buffered(&mut reader, false).map_err(|e| fail(&e))?;
    for h in &meta.headers {
        let size = h.layer_size;
        if size.width() > MAX_EXR_SIDE || size.height() > MAX_EXR_SIDE {
            bail!(
                "cannot read EXR '{}': it is {}×{}, larger than any image lightlearn writes (at most {MAX_EXR_SIDE} a side)",
                path.display(),
                size.width(),
                size.height()
            );
        }
    }
    // A layer with channels named R, G and B, as the reader below takes them: a luminance
    // (Y) reference was refused as the exr crate's "no layer in the image matched your
    // specified requirements" (an audit, 2026-12-07).
    let rgb = |h: &exr::meta::header::Header| {
        ["R", "G", "B"]
            .iter()
            .all(|c| h.channels.list.iter().any(|ch| ch.name.to_string() == *c))
    };
    if !meta.headers.iter().any(rgb) {
        let names: Vec<String> = (meta.headers.iter())
            .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
            .collect();
        // Layered files (Blender's `ViewLayer.Combined.R`): the layer to take is the fix.
        let prefixed = names.iter().find(|n| n.ends_with(".R"));
        let fix = match prefixed.map(|r| &r[..r.len() - 1]) {
            Some(layer) => format!("take one layer's channels as R, G, B (e.g. oiiotool IN --ch R={layer}R,G={layer}G,B={layer}B -o OUT)"),
            None => "convert it to RGB (e.g. oiiotool IN --ch R=Y,G=Y,B=Y -o OUT)".to_string(),
        };
        bail!(
            "cannot read EXR '{}': it has no channels named R, G, B (it has {}); lightlearn reads RGB images: {fix}",
            path.display(),
            names.join(", ")
        );
    }
    reader.seek(SeekFrom::Start(0)).map_err(|e| fail(&e))?;
    // read_first_rgba_layer_from_file's reader, on the file already open.
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| {
                let w = res.width();
                (w, vec![[0f32; 3]; w * res.height()])
            },
            |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(reader)
        .map_err(|e| fail(&e))?;
    let size = image.layer_data.size;
    let (_, px) = image.layer_data.channel_data.pixels;
    Ok((size.width() as u32, size.height() as u32, px))
}

/// sRGB transfer function of a linear value clamped to [0, 1].
fn srgb8(v: f32) -> u8 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Linear radiance → 8-bit sRGB bytes (clamped to [0, 1], no exposure change).
pub fn tonemap_srgb8(rgb: &[[f32; 3]]) -> Vec<u8> {
    rgb.iter().flat_map(|p| p.map(srgb8)).collect()
}

/// PNG file bytes of 8-bit RGB pixels.
pub fn png_bytes(width: u32, height: u32, rgb8: &[u8]) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut w = enc.write_header()?;
        w.write_image_data(rgb8)?;
        w.finish()?;
    }
    Ok(out)
}

/// 8-bit sRGB PNG: linear radiance clamped to [0, 1] (no exposure change).
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<()> {
    std::fs::write(path, png_bytes(width, height, &tonemap_srgb8(rgb))?)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The checksum reads regular files only: a FIFO where a cached reference's EXR goes
    /// blocked its open for good (a review, twenty-second session). The call runs on a
    /// thread so that a regression fails here instead of hanging the suite.
    #[test]
    fn checksums_refuse_fifos_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("f.exr");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || tx.send(exr_checksum(&fifo).map_err(|e| e.to_string())));
        let got = rx
            .recv_timeout(std::time::Duration::from_secs(20))
            .expect("the checksum of a FIFO blocked");
        assert!(got.unwrap_err().contains("not a regular file"));
        let file = dir.path().join("x.exr");
        std::fs::write(&file, b"abc").unwrap();
        assert_eq!(
            exr_checksum(&file).unwrap(),
            format!("{:016x}", crate::fnv::fnv1a(b"abc"))
        );
    }

    /// A luminance-only EXR (a Y channel) is named as such, with its channels and a fix,
    /// instead of the exr crate's "no layer in the image matched your specified
    /// requirements" (an audit, 2026-12-07); an RGB one still reads.
    #[test]
    fn exrs_without_rgb_channels_are_named() {
        use exr::prelude::*;
        let dir = tempfile::tempdir().unwrap();
        let y = dir.path().join("y.exr");
        let channel = AnyChannel::new("Y", FlatSamples::F32(vec![0.5; 6]));
        Image::from_channels((3, 2), AnyChannels::sort(vec![channel].into()))
            .write()
            .to_file(&y)
            .unwrap();
        let e = read_exr(&y).unwrap_err().to_string();
        assert!(
            e.contains("y.exr") && e.contains("no channels named R, G, B (it has Y)"),
            "{e}"
        );
        // A layered file's channels (`L.R`, …) are not read as R, G, B: named, with the fix.
        let layered = dir.path().join("l.exr");
        let chans: Vec<AnyChannel<FlatSamples>> = ["L.B", "L.G", "L.R"]
            .iter()
            .map(|n| AnyChannel::new(*n, FlatSamples::F32(vec![0.5; 6])))
            .collect();
        Image::from_channels((3, 2), AnyChannels::sort(chans.into()))
            .write()
            .to_file(&layered)
            .unwrap();
        let e = read_exr(&layered).unwrap_err().to_string();
        assert!(e.contains("R=L.R,G=L.G,B=L.B"), "{e}");
        let rgb = dir.path().join("rgb.exr");
        write_exr(&rgb, 3, 2, &[[0.5; 3]; 6]).unwrap();
        assert_eq!(read_exr(&rgb).unwrap(), (3, 2, vec![[0.5; 3]; 6]));
    }
}
