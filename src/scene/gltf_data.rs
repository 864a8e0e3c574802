//! The data of a glTF file: its buffers (GLB chunk, `data:` URIs, files beside it) and its
//! base-colour images (PNG and JPEG), for the loader.

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
    /// The texture's image decoded (PNG or JPEG; the error says why it cannot be used), when
    /// its words and the `words_before` of the textures already decoded stay within
    /// [`MAX_SCENE_TEXEL_WORDS`] (checked from the PNG's header, before decoding).
    /// `linear`: data, not colour ([`Texture::linear`]).
    pub(super) fn decode(
        &self,
        t: &gltf::Texture,
        words_before: u64,
        linear: bool,
    ) -> Result<Texture> {
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
                    DATA_URI_BASE64.decode(payload).map_err(|e| {
                        anyhow!(
                            "image {}: bad base64 data ({e}); encode it again",
                            image.index()
                        )
                    })?
                } else {
                    if let Some(scheme) = remote(uri) {
                        bail!("image {} is at '{uri}', a {scheme} address; lightlearn reads files only: download it next to '{}' and give its file name as the uri", image.index(), self.file);
                    }
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
        let index = image.index();
        let (w, h, words, wide) = if bytes.starts_with(b"\x89PNG") {
            decode_png(bytes, index, words_before)?
        } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
            decode_jpeg(bytes, index, words_before)?
        } else {
            bail!("image {index} is neither a PNG nor a JPEG (the formats glTF allows)");
        };
        let wrap = |m: gltf::texture::WrappingMode| match m {
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        };
        let s = t.sampler();
        Ok(Texture {
            width: w,
            height: h,
            words,
            wide,
            nearest: s.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
            wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())],
            linear,
        })
    }
}

/// A PNG's texels as [`Texture::words`]: (width, height, words, 16 bits a channel).
fn decode_png(
    bytes: Vec<u8>,
    index: usize,
    words_before: u64,
) -> Result<(u32, u32, Vec<u32>, bool)> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    // 16-bit channels stay 16 bits (STRIP_16 kept the high byte: up to 9 % dark).
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder
        .read_info()
        .map_err(|e| anyhow!("image {index}: {e}"))?;
    // The header's size decides the allocation below: a 5-KB PNG that claims
    // 100000×100000 asked for 30 GB and aborted the process.
    let (w, h) = (reader.info().width as u64, reader.info().height as u64);
    // EXPAND widens depths below 8 to 8 and leaves 16 as it is: the header tells the words.
    let wide = reader.info().bit_depth == png::BitDepth::Sixteen;
    let per = if wide { 2 } else { 1 };
    check_texels(index, w, h, w * h * per as u64, words_before)?;
    if reader.output_buffer_size() as u64 > 8 * MAX_TEXELS {
        bail!("image {index} is {w}×{h} texels; lightlearn reads textures of at most {MAX_TEXELS} texels (8192×8192): scale it down");
    }
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let frame = reader
        .next_frame(&mut buf)
        .map_err(|e| anyhow!("image {index}: {e}"))?;
    let (w, h) = (frame.width, frame.height);
    let data = &buf[..frame.buffer_size()];
    let channels = match frame.color_type {
        png::ColorType::Rgba => 4,
        png::ColorType::Rgb => 3,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Grayscale => 1,
        png::ColorType::Indexed => bail!("image {index}: palette not expanded"),
    };
    // One texel's channels as RGBA (grey is all three; alpha 1 when absent), at the
    // file's depth: 16-bit samples are big-endian in PNG.
    let sample = |c: &[u8], k: usize| -> u32 {
        if wide {
            u16::from_be_bytes([c[2 * k], c[2 * k + 1]]) as u32
        } else {
            c[k] as u32
        }
    };
    let one = if wide { 0xffff } else { 0xff };
    let rgba = |c: &[u8]| -> [u32; 4] {
        match channels {
            4 => [sample(c, 0), sample(c, 1), sample(c, 2), sample(c, 3)],
            3 => [sample(c, 0), sample(c, 1), sample(c, 2), one],
            2 => [sample(c, 0), sample(c, 0), sample(c, 0), sample(c, 1)],
            _ => [sample(c, 0), sample(c, 0), sample(c, 0), one],
        }
    };
    let stride = channels * per as usize;
    let texels = data.chunks_exact(stride).map(rgba);
    let words: Vec<u32> = if wide {
        texels
            .flat_map(|[r, g, b, a]| [r | g << 16, b | a << 16])
            .collect()
    } else {
        texels.map(rgba8_word).collect()
    };
    if w == 0 || h == 0 || words.len() != (w * h * per) as usize {
        bail!("image {index} has a bad size {w}×{h}");
    }
    Ok((w, h, words, wide))
}

/// A JPEG's texels as [`Texture::words`] (RGB, 8 bits; grey and CMYK converted by the
/// decoder). JPEG was skipped with a warning before 2026-12-07, and it is the format most
/// exporters write base colours in.
fn decode_jpeg(
    bytes: Vec<u8>,
    index: usize,
    words_before: u64,
) -> Result<(u32, u32, Vec<u32>, bool)> {
    use zune_jpeg::zune_core::{
        bytestream::ZCursor, colorspace::ColorSpace, options::DecoderOptions,
    };
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
        .set_max_width(1 << 16)
        .set_max_height(1 << 16);
    // A file cut short decodes with filler texels by default; strict decoding would also
    // refuse what libjpeg reads with a warning (a review, 2026-12-07), so the end-of-image
    // marker is looked for instead.
    if !bytes.windows(2).any(|w| w == [0xff, 0xd9]) {
        bail!("image {index}: a JPEG cut short (no end-of-image marker); export it again");
    }
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder
        .decode_headers()
        .map_err(|e| anyhow!("image {index}: not a JPEG lightlearn can read ({e:?})"))?;
    let (w, h) = decoder
        .dimensions()
        .ok_or_else(|| anyhow!("image {index}: a JPEG without a size"))?;
    // Grey, YCbCr/RGB and CMYK/YCCK convert to RGB; the decoder copies two components as
    // they are into an RGB-sized buffer (a review, 2026-12-07).
    let components = decoder.info().map_or(0, |i| i.components);
    if ![1, 3, 4].contains(&components) {
        bail!("image {index}: a JPEG of {components} colour components; lightlearn reads grey, colour and CMYK JPEGs: save it as one of those");
    }
    let (w, h) = (w as u64, h as u64);
    check_texels(index, w, h, w * h, words_before)?;
    let rgb = decoder
        .decode()
        .map_err(|e| anyhow!("image {index}: a damaged JPEG ({e:?})"))?;
    if w == 0 || h == 0 || rgb.len() as u64 != 3 * w * h {
        bail!("image {index} has a bad size {w}×{h}");
    }
    let words = rgb
        .chunks_exact(3)
        .map(|c| rgba8_word([c[0] as u32, c[1] as u32, c[2] as u32, 0xff]))
        .collect();
    Ok((w as u32, h as u32, words, false))
}

/// One 8-bit RGBA texel as the kernels read it (`unpackUnorm4x8`: R in the low byte).
fn rgba8_word([r, g, b, a]: [u32; 4]) -> u32 {
    r | g << 8 | b << 16 | a << 24
}

/// Errors unless an image of w×h texels (`words` words) fits one texture's limit and, with
/// the `words_before` of the scene's textures already decoded, the scene's.
fn check_texels(index: usize, w: u64, h: u64, words: u64, words_before: u64) -> Result<()> {
    if w * h > MAX_TEXELS {
        bail!(
            "image {index} is {w}×{h} texels; lightlearn reads textures of at most {MAX_TEXELS} texels (8192×8192): scale it down"
        );
    }
    // The scene's textures together: each was checked alone, so 24 textures of one
    // 82-KB 8192² PNG decoded 6 GB before any total was checked (an audit, 2026-12-07).
    if words_before + words > MAX_SCENE_TEXEL_WORDS {
        bail!(
            "image {index} ({w}×{h}) would take the scene's textures past {} MiB; lightlearn holds at most that: scale them down",
            (MAX_SCENE_TEXEL_WORDS * 4) >> 20
        );
    }
    Ok(())
}

/// The most texels of one texture (8192², 256 MiB as RGBA8).
const MAX_TEXELS: u64 = 1 << 26;
/// The most words (4 bytes) the scene's textures take together on the host: 1 GiB, four
/// textures of MAX_TEXELS (the device's buffer is the tighter limit on most devices, checked
/// after loading, `render::check_fits`).
pub(super) const MAX_SCENE_TEXEL_WORDS: u64 = 1 << 28;
/// The largest image file read (a PNG of MAX_TEXELS compresses far below this).
const MAX_IMAGE_FILE_BYTES: u64 = 1 << 30;

/// data: URIs' base64 with or without its `=` padding: RFC 2397 data URIs are read so by the
/// Khronos validator and browsers' loaders, and a file without it was refused as "Invalid
/// padding" (an audit, 2026-12-07).
const DATA_URI_BASE64: base64::engine::GeneralPurpose = base64::engine::GeneralPurpose::new(
    &base64::alphabet::STANDARD,
    base64::engine::GeneralPurposeConfig::new()
        .with_decode_padding_mode(base64::engine::DecodePaddingMode::Indifferent),
);

/// The files a glTF/GLB scene is read from: the file itself and the buffers and images it
/// names by URI (beside it), for the commands' check that no output lands on one (a render
/// of a scene whose texture was `box.png`, with `--out box.exr`, replaced the texture). A
/// file that cannot be parsed lists itself alone: loading it says what is wrong.
pub fn input_files(path: &Path) -> Vec<std::path::PathBuf> {
    let mut files = vec![path.to_path_buf()];
    let Ok(bytes) = crate::io::read_regular(path, 1 << 34) else {
        return files;
    };
    let Ok((gltf, _)) = super::gltf_parse::parse(&bytes, "") else {
        return files;
    };
    let base = path.parent().unwrap_or(Path::new(""));
    // From the JSON, not the crate's wrappers: an image whose bufferView or buffer is out of
    // range, or that has neither a uri nor a bufferView, made them panic here, before the
    // loader's checks could name it (an audit, 2026-12-06: exit 101 and a backtrace).
    let root = gltf.as_json();
    let uris = root
        .buffers
        .iter()
        .filter_map(|b| b.uri.clone())
        .chain(root.images.iter().filter_map(|i| i.uri.clone()));
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
                    DATA_URI_BASE64.decode(payload).map_err(|e| {
                        anyhow!(
                            "'{name}': buffer {}: bad base64 data ({e}); encode it again",
                            buffer.index()
                        )
                    })?
                } else {
                    if let Some(scheme) = remote(uri) {
                        bail!("'{name}': buffer {} is at '{uri}', a {scheme} address; lightlearn reads files only: download it next to the .gltf and give its file name as the uri", buffer.index());
                    }
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

/// A sparse accessor's indices are strictly increasing and below its count (glTF 2.0
/// §3.6.2.3). The crate substitutes a sparse value only where its index meets the element
/// being read, so one out of range or out of order was dropped without a word (an audit,
/// 2026-12-06: an index of 50 in a 4-element accessor left the mesh as if unedited).
/// `what`: the accessor's role, for the message.
pub(super) fn check_sparse(
    accessor: &gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
) -> Result<()> {
    let Some(sparse) = accessor.sparse() else {
        return Ok(());
    };
    let (n, a) = (sparse.count(), accessor.index());
    // glTF: 1 ≤ count ≤ the accessor's count; the crate takes count − 1 (wrapping at 0) and
    // sizes what it reads by count × the element (2^62 wrapped to 0: the edit dropped).
    if n == 0 || n > accessor.count() {
        bail!("{what}: accessor {a} has {n} sparse values for {} elements; glTF asks for 1 to its count", accessor.count());
    }
    let indices = sparse.indices();
    let view = indices.view();
    // glTF forbids a stride on sparse views; the crate would read by it, this check not.
    if view.stride().is_some() || sparse.values().view().stride().is_some() {
        bail!("{what}: accessor {a}'s sparse data lie in a buffer view with a byteStride, which glTF forbids there; remove it");
    }
    let size = indices.index_type().size();
    let len = size.checked_mul(n);
    let in_view = len
        .and_then(|l| indices.offset().checked_add(l))
        .is_some_and(|end| end <= view.length());
    let start = view.offset().checked_add(indices.offset());
    let bytes = start
        .zip(len)
        .filter(|_| in_view)
        .and_then(|(start, l)| {
            buffers
                .get(view.buffer().index())?
                .get(start..start.checked_add(l)?)
        })
        .ok_or_else(|| {
            anyhow!("{what}: accessor {a}'s sparse indices lie outside their buffer view")
        })?;
    let mut last: Option<u64> = None;
    for (k, chunk) in bytes.chunks_exact(size).enumerate() {
        let i = chunk
            .iter()
            .rev()
            .fold(0u64, |v, b| (v << 8) | u64::from(*b));
        if i >= accessor.count() as u64 || last.is_some_and(|l| i <= l) {
            bail!(
                "{what}: accessor {a}'s sparse index {k} is {i}, but they must increase and stay below its count {}; fix the sparse data",
                accessor.count()
            );
        }
        last = Some(i);
    }
    Ok(())
}

/// The scheme of a URI that names a place other than a file (`https://…`), whose path read
/// beside the scene was "No such file" (an audit, 2026-12-06). A relative path has none: glTF
/// URIs are RFC 3986 references, and a scheme is letters before "://" (`file:` included:
/// lightlearn reads paths relative to the scene only).
fn remote(uri: &str) -> Option<&str> {
    let (scheme, _) = uri.split_once("://")?;
    (!scheme.is_empty()
        && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.')))
    .then_some(scheme)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scene's textures together stay within MAX_SCENE_TEXEL_WORDS, checked from the
    /// PNG's header before decoding (an audit, 2026-12-07: 24 textures of one 8192² PNG
    /// decoded 6 GB first).
    #[test]
    fn the_scene_texture_budget_is_checked_before_decoding() {
        let mut png = Vec::new();
        let mut e = png::Encoder::new(&mut png, 2, 2);
        e.set_color(png::ColorType::Grayscale);
        e.set_depth(png::BitDepth::Sixteen);
        let mut w = e.write_header().unwrap();
        w.write_image_data(&[0u8; 8]).unwrap();
        w.finish().unwrap();
        let mut g = crate::scene::gltf_write::GltfBuilder::new();
        let m = g.material("m", glam::Vec3::ONE, glam::Vec3::ZERO, false);
        let t = g.texture_png(&png, [10497, 10497]);
        g.set_base_color_texture(m, t);
        let gltf = gltf::Gltf::from_slice(&g.to_glb()).unwrap();
        let buffers = vec![gltf.blob.clone().unwrap()];
        let images = Images {
            buffers: &buffers,
            base: Path::new("."),
            file: "t.glb",
        };
        let tex = gltf.document.textures().next().unwrap();
        // 2×2 texels at 16 bits: 8 words.
        let ok = images
            .decode(&tex, MAX_SCENE_TEXEL_WORDS - 8, false)
            .unwrap();
        assert!(ok.wide && ok.words.len() == 8);
        let err = images
            .decode(&tex, MAX_SCENE_TEXEL_WORDS - 7, false)
            .unwrap_err();
        assert!(err.to_string().contains("1024 MiB"), "{err}");
        // The same PNG cut inside its data: decoding fails, but over the budget it is the
        // budget that is named, so the check comes before the decoder reads the texels.
        let cut = png[..png.len() - 16].to_vec();
        let mut g = crate::scene::gltf_write::GltfBuilder::new();
        let m = g.material("m", glam::Vec3::ONE, glam::Vec3::ZERO, false);
        let t = g.texture_png(&cut, [10497, 10497]);
        g.set_base_color_texture(m, t);
        let gltf = gltf::Gltf::from_slice(&g.to_glb()).unwrap();
        let images = Images {
            buffers: &[gltf.blob.clone().unwrap()],
            ..images
        };
        let tex = gltf.document.textures().next().unwrap();
        let err = images.decode(&tex, 0, false).unwrap_err();
        assert!(!err.to_string().contains("MiB"), "{err}");
        let err = images
            .decode(&tex, MAX_SCENE_TEXEL_WORDS - 7, false)
            .unwrap_err();
        assert!(err.to_string().contains("1024 MiB"), "{err}");
    }
}
