//! The data of a glTF file: its buffers (GLB chunk, `data:` URIs, files beside it) and its
//! base-colour images (PNG), for the loader.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use base64::Engine;

use super::{Texture, Wrap};

/// Where a glTF file's images come from: its buffers and folder.
pub(super) struct Images<'a> {
    pub buffers: &'a [Vec<u8>],
    pub base: &'a Path,
    pub file: &'a str,
}

impl Images<'_> {
    /// The texture's image decoded (PNG only; the error says why it cannot be used).
    pub(super) fn decode(&self, t: &gltf::Texture) -> Result<Texture> {
        let image = t.source();
        let bytes: Vec<u8> = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let data = self
                    .buffers
                    .get(view.buffer().index())
                    .ok_or_else(|| anyhow!("image {} lies in a missing buffer", image.index()))?;
                data.get(view.offset()..view.offset() + view.length())
                    .ok_or_else(|| {
                        anyhow!(
                            "image {}'s buffer view lies outside its buffer",
                            image.index()
                        )
                    })?
                    .to_vec()
            }
            gltf::image::Source::Uri { uri, .. } => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
                        anyhow!("image {} has a data: URI that is not base64", image.index())
                    })?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| anyhow!("image {}: bad base64 data ({e})", image.index()))?
                } else {
                    let path = self.base.join(percent_decode(uri));
                    crate::io::read_regular(&path, MAX_IMAGE_FILE_BYTES).map_err(|e| {
                        anyhow!(
                            "cannot read image '{}' ({e}); keep it next to '{}'",
                            path.display(),
                            self.file
                        )
                    })?
                }
            }
        };
        if !bytes.starts_with(b"\x89PNG") {
            bail!(
                "image {} is not a PNG (only PNG textures are supported so far)",
                image.index()
            );
        }
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut reader = decoder
            .read_info()
            .map_err(|e| anyhow!("image {}: {e}", image.index()))?;
        // The header's size decides the allocation below: a 5-KB PNG that claims
        // 100000×100000 asked for 30 GB and aborted the process.
        let (w, h) = (reader.info().width as u64, reader.info().height as u64);
        if w * h > MAX_TEXELS || reader.output_buffer_size() as u64 > 8 * MAX_TEXELS {
            bail!(
                "image {} is {w}×{h} texels; lightlearn reads textures of at most {MAX_TEXELS} texels (8192×8192): scale it down",
                image.index()
            );
        }
        let mut buf = vec![0u8; reader.output_buffer_size()];
        let frame = reader
            .next_frame(&mut buf)
            .map_err(|e| anyhow!("image {}: {e}", image.index()))?;
        let (w, h) = (frame.width, frame.height);
        let data = &buf[..frame.buffer_size()];
        let texels: Vec<[u8; 4]> = match frame.color_type {
            png::ColorType::Rgba => data
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect(),
            png::ColorType::Rgb => data
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2], 255])
                .collect(),
            png::ColorType::GrayscaleAlpha => data
                .chunks_exact(2)
                .map(|c| [c[0], c[0], c[0], c[1]])
                .collect(),
            png::ColorType::Grayscale => data.iter().map(|&g| [g, g, g, 255]).collect(),
            png::ColorType::Indexed => bail!("image {}: palette not expanded", image.index()),
        };
        if w == 0 || h == 0 || texels.len() != (w * h) as usize {
            bail!("image {} has a bad size {w}×{h}", image.index());
        }
        let wrap = |m: gltf::texture::WrappingMode| match m {
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        };
        let s = t.sampler();
        Ok(Texture {
            width: w,
            height: h,
            texels,
            wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())],
        })
    }
}

/// The most texels of one texture (8192², 256 MiB as RGBA8).
const MAX_TEXELS: u64 = 1 << 26;
/// The largest image file read (a PNG of MAX_TEXELS compresses far below this).
const MAX_IMAGE_FILE_BYTES: u64 = 1 << 30;

/// The files a glTF/GLB scene is read from: the file itself and the buffers and images it
/// names by URI (beside it), for the commands' check that no output lands on one (a render
/// of a scene whose texture was `box.png`, with `--out box.exr`, replaced the texture). A
/// file that cannot be parsed lists itself alone: loading it says what is wrong.
pub fn input_files(path: &Path) -> Vec<std::path::PathBuf> {
    let mut files = vec![path.to_path_buf()];
    let Ok(bytes) = crate::io::read_regular(path, 1 << 34) else {
        return files;
    };
    let Ok(gltf) = gltf::Gltf::from_slice_without_validation(&bytes) else {
        return files;
    };
    let base = path.parent().unwrap_or(Path::new(""));
    let uris = gltf
        .document
        .buffers()
        .filter_map(|b| match b.source() {
            gltf::buffer::Source::Uri(u) => Some(u.to_string()),
            gltf::buffer::Source::Bin => None,
        })
        .chain(gltf.document.images().filter_map(|i| match i.source() {
            gltf::image::Source::Uri { uri, .. } => Some(uri.to_string()),
            gltf::image::Source::View { .. } => None,
        }));
    for uri in uris.filter(|u| !u.starts_with("data:")) {
        files.push(base.join(percent_decode(&uri)));
    }
    files
}

pub(super) fn load_buffers(gltf: &gltf::Gltf, name: &str, base: &Path) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                anyhow!(
                    "'{name}': buffer {} refers to the GLB binary chunk, but the file has none",
                    buffer.index()
                )
            })?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
                        anyhow!(
                            "'{name}': buffer {} has a data: URI that is not base64",
                            buffer.index()
                        )
                    })?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| {
                            anyhow!("'{name}': buffer {}: bad base64 data ({e})", buffer.index())
                        })?
                } else {
                    let path: PathBuf = base.join(percent_decode(uri));
                    // At most the declared length: a longer file's tail is not the buffer
                    // (and /dev/zero as a URI read until memory ran out).
                    crate::io::read_regular(&path, buffer.length() as u64).with_context(|| {
                        format!(
                            "'{name}': cannot read buffer {} from '{}'; keep the .bin file next to the .gltf",
                            buffer.index(),
                            path.display()
                        )
                    })?
                }
            }
        };
        if data.len() < buffer.length() {
            bail!(
                "'{name}': buffer {} holds {} bytes but declares {}; the file is truncated",
                buffer.index(),
                data.len(),
                buffer.length()
            );
        }
        out.push(data);
    }
    Ok(out)
}

/// A relative URI's `%XX` escapes decoded (glTF URIs are percent-encoded: `my%20data.bin`).
pub fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = std::str::from_utf8(&b[i + 1..i + 3]).ok();
            if let Some(v) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}
