//! Photoshop (`.psd`) import: the layered file Photoshop, Krita, GIMP, Photopea and Clip Studio
//! save (Adobe's "Photoshop File Formats Specification", sections "File Header", "Layer and Mask
//! Information", "Channel Image Data", "Additional Layer Information").
//!
//! Only what a layered 8-bit RGB document needs is read: the header, the layer records (bounds,
//! channels, blend mode, opacity, visibility, name — the Unicode `luni` name where the file has
//! one, else the legacy Pascal name read as Mac Roman — and the `lsct` group markers) and the raw
//! or RLE (PackBits) channel data; the colour-mode data, image resources, merged image and masks
//! are skipped. Records are stored bottom (back) first, which is already our order. A group is a
//! closing "section divider" record below its layers and an opening record above them carrying
//! the group's name, visibility, opacity and blend mode; a hidden group hides its layers and a
//! group's opacity multiplies theirs. Layers inside a group named `accessories` are accessories;
//! all others are body parts. The root is the body layer with the most opaque pixels. Every
//! overlapping pair of layers is joined. A `character.toml` beside the file may say otherwise
//! ([`super::character::LayeredOverrides`]).
//!
//! The reader is our own rather than the `psd` crate's: that crate slices by lengths read from
//! the file without checking them (chinedufn/psd#70, an open RustSec draft, and index panics in
//! its channel decoder, #57), drops the Unicode names and reports no section markers, and a
//! panic on a user's file is what this import must never do. Here every length is checked
//! against the bytes left before it is used, the header (signature, version 1, 8 bits per
//! channel, RGB) is validated before anything else, and the canvas, the count of visible layers
//! and every layer's bounds (inside the canvas) are checked against [`ImportOptions`] before any
//! channel is decoded, so memory is bounded by the limits, never by numbers in the file.

use std::path::Path;

use super::layers::{assemble, place, ArtLayer, Artwork, ImportOptions};
use super::LayerKind;
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::user_file;

/// The most channels a document may have (the specification's range is 1–56).
const MAX_CHANNELS: u16 = 56;

/// The longest `.psd` file read: every layer at the most the import allows
/// ([`ImportOptions::max_total_pixels`]) as uncompressed RGBA plus the worst case of RLE over it
/// (one header byte per 128 and two bytes of row count per row, under 1/16 more), plus a merged
/// image and 16 MiB for resources and masks — 432 MiB by default (real files are far smaller:
/// `data/psd/robot_krita.psd`, ten layers of at most 96×128, is 44 KB).
pub fn max_file_bytes(opts: &ImportOptions) -> u64 {
    let layers = opts.max_total_pixels.saturating_mul(4);
    layers
        .saturating_add(layers / 16)
        .saturating_add(opts.image.max_file_bytes())
        .saturating_add(16 << 20)
}

/// Reads a `.psd` file; blend modes other than normal and layer masks are reported to
/// `progress`.
///
/// # Errors
/// [`Error::Io`] if unreadable; [`Error::Limit`] if it is longer than [`max_file_bytes`]; as
/// [`from_bytes`] for its contents.
pub fn load(path: &Path, opts: &ImportOptions, progress: &dyn Progress) -> Result<Artwork> {
    let bytes = user_file::read_bytes(path, max_file_bytes(opts))?;
    from_bytes(&bytes, path, opts, progress)
}

/// Reads the bytes of a `.psd` file; `path` names it in errors and gives the character its name.
///
/// # Errors
/// [`Error::Format`] for a file that is not a Photoshop document, is truncated, is not 8-bit RGB
/// (16/32-bit, CMYK, grayscale, indexed…), is a large-document `.psb`, has no layers or no visible
/// ones, or has a malformed record; [`Error::Layer`] for a layer that extends past the canvas,
/// has undecodable or ZIP-compressed channels, is fully transparent or shares its name with
/// another; [`Error::Limit`] for a canvas or layer count past the limits.
pub fn from_bytes(bytes: &[u8], path: &Path, opts: &ImportOptions, progress: &dyn Progress) -> Result<Artwork> {
    let mut r = Reader { bytes, pos: 0, base: 0 };
    let (width, height) = header(&mut r).map_err(|p| Error::format(path, p))?;
    opts.image.check(width, height).map_err(|e| e.with_path(path))?;
    let records = layer_records(&mut r).map_err(|p| Error::format(path, p))?;
    if records.is_empty() {
        return Err(Error::format(
            path,
            "no layers (the document holds only a flattened image: save it with its layers)",
        ));
    }
    let visible = visible_layers(&records, path, progress)?;
    if visible.is_empty() {
        return Err(Error::format(path, "no visible layers (every layer is hidden, or a group)"));
    }
    opts.check(visible.len(), width, height).map_err(|e| e.with_path(path))?;
    let mut layers = Vec::new();
    let mut problems = Vec::new();
    for layer in &visible {
        let record = &records[layer.record];
        let [top, left, bottom, right] = record.bounds;
        if top < 0 || left < 0 || i64::from(bottom) > i64::from(height) || i64::from(right) > i64::from(width) {
            problems.push(Error::layer(
                path,
                &record.name,
                format!(
                    "its bounds, x {left}..{right} and y {top}..{bottom}, extend past the {width}×{height} canvas \
                     (crop the layer to the canvas in the editor)"
                ),
            ));
            continue;
        }
        match pixels(record, bytes) {
            Ok(pic) => layers.push(ArtLayer {
                name: record.name.clone(),
                kind: if layer.accessory { LayerKind::Accessory } else { LayerKind::Body },
                picture: place(&pic, [i64::from(left), i64::from(top)], layer.opacity, width, height),
            }),
            Err(problem) => problems.push(Error::layer(path, &record.name, problem)),
        }
    }
    assemble(path, layers, problems, progress)
}

/// A cursor over the file's bytes whose reads fail, with the offset, where the file ends.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Where `bytes` starts in the file.
    base: usize,
}

impl<'a> Reader<'a> {
    /// The next `n` bytes.
    fn take(&mut self, n: usize, what: &str) -> std::result::Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| {
            format!(
                "truncated: {what} needs {n} bytes at offset {}, but the file ends at {}",
                self.pos,
                self.bytes.len()
            )
        })?;
        let out = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, what: &str) -> std::result::Result<[u8; N], String> {
        let mut out = [0; N];
        out.copy_from_slice(self.take(N, what)?);
        Ok(out)
    }

    fn u8(&mut self, what: &str) -> std::result::Result<u8, String> {
        Ok(self.array::<1>(what)?[0])
    }

    fn u16(&mut self, what: &str) -> std::result::Result<u16, String> {
        self.array(what).map(u16::from_be_bytes)
    }

    fn i16(&mut self, what: &str) -> std::result::Result<i16, String> {
        self.array(what).map(i16::from_be_bytes)
    }

    fn u32(&mut self, what: &str) -> std::result::Result<u32, String> {
        self.array(what).map(u32::from_be_bytes)
    }

    fn i32(&mut self, what: &str) -> std::result::Result<i32, String> {
        self.array(what).map(i32::from_be_bytes)
    }

    /// A section that starts with its own 4-byte length: a reader over just its bytes.
    fn section(&mut self, what: &str) -> std::result::Result<Reader<'a>, String> {
        let len = self.u32(what)? as usize;
        let base = self.base + self.pos;
        Ok(Reader {
            bytes: self.take(len, what)?,
            pos: 0,
            base,
        })
    }

    fn left(&self) -> usize {
        self.bytes.len() - self.pos
    }
}

/// Reads and checks the 26-byte file header; the canvas `(width, height)`.
fn header(r: &mut Reader) -> std::result::Result<(u32, u32), String> {
    if r.bytes.len() >= 4 && &r.bytes[..4] != b"8BPS" {
        return Err("not a Photoshop document (no 8BPS signature)".into());
    }
    r.take(4, "the signature")?;
    match r.u16("the version")? {
        1 => {}
        2 => return Err("a large-document .psb (version 2) is not supported: save it as .psd".into()),
        v => return Err(format!("unknown version {v} (expected 1)")),
    }
    r.take(6, "the header")?;
    let channels = r.u16("the channel count")?;
    let height = r.u32("the height")?;
    let width = r.u32("the width")?;
    let depth = r.u16("the depth")?;
    let mode = r.u16("the colour mode")?;
    if !(1..=MAX_CHANNELS).contains(&channels) {
        return Err(format!("{channels} channels (expected 1 to {MAX_CHANNELS})"));
    }
    if depth != 8 {
        return Err(format!(
            "{depth}-bit channels: only 8 bits per channel are supported (convert the document to 8 bits per channel)"
        ));
    }
    if mode != 3 {
        let name = match mode {
            0 => "bitmap",
            1 => "grayscale",
            2 => "indexed",
            4 => "CMYK",
            7 => "multichannel",
            8 => "duotone",
            9 => "Lab",
            _ => "unknown",
        };
        return Err(format!(
            "{name} colour mode ({mode}): only RGB documents are supported (convert the document to RGB)"
        ));
    }
    if width == 0 || height == 0 {
        return Err(format!("a {width}×{height} canvas"));
    }
    Ok((width, height))
}

/// A layer record, with where its channels' data lies in the file.
struct Record {
    name: String,
    /// Top, left, bottom, right.
    bounds: [i32; 4],
    /// Channel id (0, 1, 2 colour, -1 transparency, -2/-3 masks) and its data in the file.
    channels: Vec<(i16, std::ops::Range<usize>)>,
    /// The blend mode key (`norm`, `mul `, …), a group's from its `lsct` block.
    blend: [u8; 4],
    opacity: u8,
    hidden: bool,
    /// `lsct`: 0 a layer, 1/2 a group's opening record (open/closed folder), 3 a group's end.
    section: u32,
}

/// Skips the colour-mode data and image resources and reads every layer record (bottom first)
/// with the offsets of its channel data; empty if the document has no layers.
fn layer_records(r: &mut Reader) -> std::result::Result<Vec<Record>, String> {
    r.section("the colour-mode data")?;
    r.section("the image resources")?;
    let mut info = r.section("the layer and mask information")?;
    if info.left() == 0 {
        return Ok(Vec::new());
    }
    let mut layers = info.section("the layer information")?;
    if layers.left() == 0 {
        return Ok(Vec::new());
    }
    // Negative: the merged image's first alpha channel is its transparency; the count is the same.
    let count = layers.i16("the layer count")?.unsigned_abs();
    let mut records = Vec::new();
    for i in 0..count {
        records.push(record(&mut layers).map_err(|p| format!("layer record {}: {p}", i + 1))?);
    }
    // The channel data follows the records, layer by layer, channel by channel.
    for record in &mut records {
        for (id, range) in &mut record.channels {
            let start = layers.base + layers.pos;
            let len = range.end;
            layers
                .take(len, "channel data")
                .map_err(|p| format!("layer {:?}, channel {id}: {p}", record.name))?;
            *range = start..start + len;
        }
    }
    Ok(records)
}

/// Reads one layer record; its channel ranges hold only their lengths until the data is found.
fn record(r: &mut Reader) -> std::result::Result<Record, String> {
    let bounds = [
        r.i32("the bounds")?,
        r.i32("the bounds")?,
        r.i32("the bounds")?,
        r.i32("the bounds")?,
    ];
    let n = r.u16("the channel count")?;
    if n > MAX_CHANNELS {
        return Err(format!("{n} channels (expected at most {MAX_CHANNELS})"));
    }
    let mut channels = Vec::new();
    for _ in 0..n {
        let id = r.i16("a channel id")?;
        let len = r.u32("a channel length")? as usize;
        channels.push((id, 0..len));
    }
    if &r.array::<4>("the blend-mode signature")? != b"8BIM" {
        return Err("no 8BIM blend-mode signature".into());
    }
    let mut blend = r.array::<4>("the blend mode")?;
    let opacity = r.u8("the opacity")?;
    r.u8("the clipping")?;
    let flags = r.u8("the flags")?;
    r.u8("the filler")?;
    let mut extra = r.section("the extra layer data")?;
    extra.section("the layer mask data")?;
    extra.section("the blending ranges")?;
    let len = extra.u8("the name")?;
    let mut name = mac_roman(extra.take(usize::from(len), "the name")?);
    // The Pascal name is padded to a multiple of 4 bytes, its length byte included.
    let pad = (4 - (1 + usize::from(len)) % 4) % 4;
    extra.take(pad.min(extra.left()), "the name's padding")?;
    let mut section = 0;
    // Additional layer information: signature, key, length, data.
    while extra.left() >= 12 {
        let signature = extra.array::<4>("a block signature")?;
        if &signature != b"8BIM" && &signature != b"8B64" {
            break;
        }
        let key = extra.array::<4>("a block key")?;
        let len = extra.u32("a block length")? as usize;
        let base = extra.base + extra.pos;
        let mut data = Reader {
            bytes: extra.take(len, "a block")?,
            pos: 0,
            base,
        };
        match &key {
            b"luni" => {
                let chars = data.u32("the Unicode name")? as usize;
                let units = data.take(chars.saturating_mul(2), "the Unicode name")?;
                let units: Vec<u16> = units.chunks_exact(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect();
                // Krita ends the name with a NUL it counts as a character.
                name = String::from_utf16_lossy(&units).trim_end_matches('\0').to_string();
            }
            b"lsct" | b"lsdk" => {
                section = data.u32("the section type")?;
                if data.left() >= 8 && data.take(4, "the section signature")? == b"8BIM" {
                    blend = data.array("the section blend mode")?;
                }
            }
            _ => {}
        }
        // Some writers pad a block to an even length without counting the pad.
        if len % 2 == 1 && extra.left() > 0 && extra.bytes.get(extra.pos..extra.pos + 4) != Some(b"8BIM") {
            extra.take(1, "a block's padding")?;
        }
    }
    Ok(Record {
        name,
        bounds,
        channels,
        blend,
        opacity,
        hidden: flags & 0b10 != 0,
        section,
    })
}

/// A visible pixel layer: its record, its opacity with its groups', whether it is an accessory.
struct Visible {
    record: usize,
    opacity: f32,
    accessory: bool,
}

/// The pixel layers that are drawn (not hidden, not in a hidden group), bottom first, with their
/// effective opacity; warns about blend modes the import draws as normal and about masks.
///
/// # Errors
/// [`Error::Format`] for group markers that do not pair up.
fn visible_layers(records: &[Record], path: &Path, progress: &dyn Progress) -> Result<Vec<Visible>> {
    // Walk top → bottom: a group's opening record comes before (above) its layers there.
    struct Group<'a> {
        name: &'a str,
        hidden: bool,
        opacity: f32,
    }
    let mut groups: Vec<Group> = Vec::new();
    let mut out = Vec::new();
    for (i, record) in records.iter().enumerate().rev() {
        let opacity = f32::from(record.opacity) / 255.0;
        match record.section {
            1 | 2 => {
                if !matches!(&record.blend, b"pass" | b"norm") {
                    progress.warn(&format!(
                        "{}: group {:?}: blend mode {:?} is not supported; its layers are drawn as they are (pass through)",
                        path.display(),
                        record.name,
                        blend_name(&record.blend)
                    ));
                }
                groups.push(Group {
                    name: &record.name,
                    hidden: record.hidden,
                    opacity,
                });
            }
            3 => {
                if groups.pop().is_none() {
                    return Err(Error::format(
                        path,
                        format!("layer record {}: a group's end with no group open", i + 1),
                    ));
                }
            }
            _ => {
                if record.hidden || groups.iter().any(|g| g.hidden) {
                    continue;
                }
                if &record.blend != b"norm" {
                    progress.warn(&format!(
                        "{}: layer {:?}: blend mode {:?} is not supported; drawn as normal",
                        path.display(),
                        record.name,
                        blend_name(&record.blend)
                    ));
                }
                if record.channels.iter().any(|(id, range)| *id <= -2 && range.len() > 2) {
                    progress.warn(&format!(
                        "{}: layer {:?}: its layer mask is ignored (apply it in the editor to keep its effect)",
                        path.display(),
                        record.name
                    ));
                }
                out.push(Visible {
                    record: i,
                    opacity: groups.iter().fold(opacity, |o, g| o * g.opacity),
                    accessory: groups.iter().any(|g| g.name.eq_ignore_ascii_case("accessories")),
                });
            }
        }
    }
    if !groups.is_empty() {
        return Err(Error::format(path, format!("group {:?} has no end marker", groups[0].name)));
    }
    out.reverse();
    Ok(out)
}

/// The readable name of a blend-mode key (Photoshop's 4-character codes, e.g. `mul `, `scrn`).
fn blend_name(key: &[u8; 4]) -> String {
    let name = match key {
        b"pass" => "pass through",
        b"norm" => "normal",
        b"diss" => "dissolve",
        b"dark" => "darken",
        b"mul " => "multiply",
        b"idiv" => "color burn",
        b"lbrn" => "linear burn",
        b"dkCl" => "darker color",
        b"lite" => "lighten",
        b"scrn" => "screen",
        b"div " => "color dodge",
        b"lddg" => "linear dodge",
        b"lgCl" => "lighter color",
        b"over" => "overlay",
        b"sLit" => "soft light",
        b"hLit" => "hard light",
        b"vLit" => "vivid light",
        b"lLit" => "linear light",
        b"pLit" => "pin light",
        b"hMix" => "hard mix",
        b"diff" => "difference",
        b"smud" => "exclusion",
        b"fsub" => "subtract",
        b"fdiv" => "divide",
        b"hue " => "hue",
        b"sat " => "saturation",
        b"colr" => "color",
        b"lum " => "luminosity",
        _ => return String::from_utf8_lossy(key).into_owned(),
    };
    name.into()
}

/// The layer's own pixels (its bounds' size, straight alpha) from its R, G, B and transparency
/// channels; a missing transparency channel means opaque.
fn pixels(record: &Record, bytes: &[u8]) -> std::result::Result<Picture, String> {
    let [top, left, bottom, right] = record.bounds;
    // The caller checked 0 ≤ left, right ≤ width (same for y), not left ≤ right: a right of
    // -2³¹ below a left ≥ 0 would overflow a plain subtraction (found by fuzz/, target psd).
    let (w, h) = (
        right.saturating_sub(left).max(0) as usize,
        bottom.saturating_sub(top).max(0) as usize,
    );
    let mut planes: [Option<Vec<u8>>; 4] = [None, None, None, None];
    for (id, range) in &record.channels {
        let slot = match id {
            0..=2 => *id as usize,
            -1 => 3,
            _ => continue,
        };
        let data = bytes.get(range.clone()).ok_or("channel data outside the file")?;
        planes[slot] = Some(channel(data, w, h).map_err(|p| format!("channel {id}: {p}"))?);
    }
    let mut pic = Picture::filled(w as u32, h as u32, [0.0; 4]);
    for (k, plane) in planes.iter().enumerate() {
        match plane {
            Some(plane) => {
                for (p, &v) in pic.pixels.iter_mut().zip(plane) {
                    p[k] = f32::from(v) / 255.0;
                }
            }
            None if k == 3 => pic.pixels.iter_mut().for_each(|p| p[3] = 1.0),
            None => return Err(format!("no channel {k} (an RGB layer has channels 0, 1 and 2)")),
        }
    }
    Ok(pic)
}

/// Decodes one channel's data (a 2-byte compression code, then raw or PackBits rows) into
/// `w × h` bytes.
fn channel(data: &[u8], w: usize, h: usize) -> std::result::Result<Vec<u8>, String> {
    let mut r = Reader {
        bytes: data,
        pos: 0,
        base: 0,
    };
    match r.u16("the compression")? {
        0 => Ok(r.take(w * h, "raw channel data")?.to_vec()),
        1 => {
            let mut counts = Vec::with_capacity(h);
            for _ in 0..h {
                counts.push(usize::from(r.u16("the RLE row lengths")?));
            }
            let mut out = Vec::with_capacity(w * h);
            for (y, &n) in counts.iter().enumerate() {
                let row = r.take(n, "an RLE row")?;
                unpack_bits(row, w, &mut out).map_err(|p| format!("row {y}: {p}"))?;
            }
            Ok(out)
        }
        2 | 3 => Err("ZIP-compressed channel data is not supported (save with RLE compression)".into()),
        c => Err(format!("unknown compression {c}")),
    }
}

/// Appends the PackBits-decoded `row`, which must be exactly `w` bytes, to `out`.
fn unpack_bits(row: &[u8], w: usize, out: &mut Vec<u8>) -> std::result::Result<(), String> {
    let start = out.len();
    let mut i = 0;
    while i < row.len() {
        let n = row[i] as i8;
        i += 1;
        let done = out.len() - start;
        if n >= 0 {
            let count = n as usize + 1;
            let literal = row.get(i..i + count).ok_or("a literal run past the row's end")?;
            if done + count > w {
                return Err(format!("decodes to more than {w} bytes"));
            }
            out.extend_from_slice(literal);
            i += count;
        } else if n != -128 {
            let count = 1 - n as isize;
            let &value = row.get(i).ok_or("a repeat run past the row's end")?;
            if done + count as usize > w {
                return Err(format!("decodes to more than {w} bytes"));
            }
            out.resize(out.len() + count as usize, value);
            i += 1;
        }
    }
    if out.len() - start != w {
        return Err(format!("decodes to {} bytes, expected {w}", out.len() - start));
    }
    Ok(())
}

/// Bytes 0x80–0xFF in Mac Roman, the legacy Pascal names' encoding in Photoshop's files.
const MAC_ROMAN: &str = "ÄÅÇÉÑÖÜáàâäãåçéèêëíìîïñóòôöõúùûü†°¢£§•¶ß®©™´¨≠ÆØ∞±≤≥¥µ∂∑∏π∫ªºΩæø¿¡¬√ƒ≈∆«»…\u{a0}ÀÃÕŒœ–—“”‘’÷◊ÿŸ⁄€‹›ﬁﬂ‡·‚„‰ÂÊÁËÈÍÎÏÌÓÔ\u{f8ff}ÒÚÛÙıˆ˜¯˘˙˚¸˝˛ˇ";

/// A legacy (Pascal) layer name as text.
fn mac_roman(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|&b| match b {
            0..=127 => char::from(b),
            _ => MAC_ROMAN.chars().nth(usize::from(b - 128)).unwrap_or('?'),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Recorder;

    /// One layer record of a test document.
    struct L {
        name: &'static [u8],
        bounds: [i32; 4],
        blend: &'static [u8; 4],
        opacity: u8,
        hidden: bool,
        section: u32,
        /// RGBA bytes, row-major over the bounds.
        rgba: Vec<[u8; 4]>,
        rle: bool,
    }

    fn layer(name: &'static [u8], bounds: [i32; 4], rgba: [u8; 4]) -> L {
        let n = ((bounds[2] - bounds[0]) * (bounds[3] - bounds[1])).max(0) as usize;
        L {
            name,
            bounds,
            blend: b"norm",
            opacity: 255,
            hidden: false,
            section: 0,
            rgba: vec![rgba; n],
            rle: false,
        }
    }

    fn group(name: &'static [u8], section: u32) -> L {
        L {
            section,
            ..layer(name, [0; 4], [0; 4])
        }
    }

    /// A `w`×`h` 8-bit RGB document with `layers` (bottom first), as the specification lays it
    /// out; no merged image.
    fn doc(w: u32, h: u32, layers: &[L]) -> Vec<u8> {
        let mut out = b"8BPS\0\x01\0\0\0\0\0\0\0\x03".to_vec();
        out.extend(h.to_be_bytes());
        out.extend(w.to_be_bytes());
        out.extend([0, 8, 0, 3]);
        out.extend([0; 8]); // colour-mode data and image resources, empty
        let (mut records, mut data) = (Vec::new(), Vec::new());
        records.extend((layers.len() as i16).to_be_bytes());
        for l in layers {
            let [top, left, bottom, right] = l.bounds;
            let (w, h) = ((right - left).max(0) as usize, (bottom - top).max(0) as usize);
            for v in l.bounds {
                records.extend(v.to_be_bytes());
            }
            records.extend(4u16.to_be_bytes());
            for (id, k) in [(-1i16, 3), (0, 0), (1, 1), (2, 2)] {
                let plane: Vec<u8> = l.rgba.iter().map(|p| p[k]).collect();
                let mut bytes = Vec::new();
                if l.rle {
                    bytes.extend(1u16.to_be_bytes());
                    bytes.extend((0..h).flat_map(|_| (w as u16 + 1).to_be_bytes()));
                    for row in plane.chunks(w.max(1)) {
                        bytes.push(w as u8 - 1);
                        bytes.extend(row);
                    }
                } else {
                    bytes.extend([0, 0]);
                    bytes.extend(&plane);
                }
                records.extend(id.to_be_bytes());
                records.extend((bytes.len() as u32).to_be_bytes());
                data.extend(bytes);
            }
            records.extend(b"8BIM");
            records.extend(l.blend);
            records.extend([l.opacity, 0, if l.hidden { 2 } else { 0 }, 0]);
            let mut extra = vec![0; 8];
            extra.push(l.name.len() as u8);
            extra.extend(l.name);
            extra.resize(8 + (1 + l.name.len()).div_ceil(4) * 4, 0);
            if l.section != 0 {
                extra.extend(b"8BIMlsct\0\0\0\x04");
                extra.extend(l.section.to_be_bytes());
            }
            records.extend((extra.len() as u32).to_be_bytes());
            records.extend(extra);
        }
        records.extend(data);
        out.extend((records.len() as u32 + 4).to_be_bytes());
        out.extend((records.len() as u32).to_be_bytes());
        out.extend(records);
        out
    }

    fn import(bytes: &[u8]) -> (Result<Artwork>, Vec<String>) {
        let recorder = Recorder::default();
        let art = from_bytes(bytes, Path::new("c.psd"), &ImportOptions::default(), &recorder);
        (art, recorder.warnings())
    }

    #[test]
    fn a_layer_reads_at_its_offset_with_its_own_and_its_groups_opacity() {
        let mut half = layer(b"arm", [1, 2, 3, 4], [255, 0, 0, 255]);
        half.opacity = 128;
        half.rle = true;
        let mut outer = group(b"accessories", 1);
        outer.opacity = 51;
        let bytes = doc(
            5,
            4,
            &[
                group(b"</Layer group>", 3),
                half,
                outer,
                layer(b"body", [0, 0, 4, 5], [0, 0, 255, 255]),
            ],
        );
        let (art, warnings) = import(&bytes);
        let art = art.unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        let names: Vec<&str> = art.layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["arm", "body"]);
        assert_eq!(art.layers[0].kind, LayerKind::Accessory);
        assert_eq!(art.layers[1].kind, LayerKind::Body);
        assert_eq!(art.root, 1);
        let arm = &art.layers[0].picture;
        let alpha: Vec<f32> = arm.pixels.iter().map(|p| p[3]).collect();
        let a = 128.0 / 255.0 * (51.0 / 255.0);
        #[rustfmt::skip]
        assert_eq!(alpha, [
            0.0, 0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, a,   a,   0.0,
            0.0, 0.0, a,   a,   0.0,
            0.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        assert_eq!(arm.get(2, 1)[..3], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn hidden_layers_and_hidden_groups_are_skipped() {
        let mut sketch = layer(b"sketch", [0, 0, 2, 2], [9; 4]);
        sketch.hidden = true;
        let mut folder = group(b"old", 2);
        folder.hidden = true;
        let bytes = doc(
            2,
            2,
            &[
                layer(b"body", [0, 0, 2, 2], [255; 4]),
                group(b"", 3),
                layer(b"inside", [0, 0, 1, 1], [255; 4]),
                folder,
                sketch,
            ],
        );
        let art = import(&bytes).0.unwrap();
        assert_eq!(art.layers.len(), 1);
        assert_eq!(art.layers[0].name, "body");
    }

    #[test]
    fn another_blend_mode_is_a_warning_naming_the_layer_and_mode() {
        let mut shade = layer(b"shade", [0, 0, 1, 1], [0, 0, 0, 255]);
        shade.blend = b"mul ";
        let mut folder = group(b"fx", 1);
        folder.blend = b"scrn";
        let bytes = doc(2, 2, &[group(b"", 3), layer(b"body", [0, 0, 2, 2], [255; 4]), folder, shade]);
        let (art, warnings) = import(&bytes);
        assert_eq!(art.unwrap().layers.len(), 2, "both layers are used");
        assert_eq!(
            warnings,
            [
                "c.psd: layer \"shade\": blend mode \"multiply\" is not supported; drawn as normal",
                "c.psd: group \"fx\": blend mode \"screen\" is not supported; its layers are drawn as they are (pass through)",
            ]
        );
    }

    #[test]
    fn a_legacy_name_is_mac_roman() {
        let art = import(&doc(1, 1, &[layer(b"\x8etoile", [0, 0, 1, 1], [255; 4])])).0.unwrap();
        assert_eq!(art.layers[0].name, "étoile");
    }

    #[test]
    fn duplicate_names_and_a_transparent_layer_are_reported_together() {
        let bytes = doc(
            2,
            2,
            &[
                layer(b"arm", [0, 0, 1, 1], [255; 4]),
                layer(b"arm", [1, 1, 2, 2], [255; 4]),
                layer(b"glass", [0, 0, 2, 2], [0; 4]),
            ],
        );
        let err = import(&bytes).0.unwrap_err().to_string();
        assert!(err.contains("c.psd: layer \"arm\": duplicate layer name"), "{err}");
        assert!(err.contains("c.psd: layer \"glass\": fully transparent"), "{err}");
    }

    #[test]
    fn a_transparent_layer_in_good_artwork_is_skipped_with_a_warning_naming_it() {
        let (art, warnings) = import(&doc(
            2,
            2,
            &[layer(b"arm", [0, 0, 1, 1], [255; 4]), layer(b"glass", [0, 0, 2, 2], [0; 4])],
        ));
        let names: Vec<String> = art.unwrap().layers.into_iter().map(|l| l.name).collect();
        assert_eq!(names, ["arm"]);
        assert_eq!(
            warnings,
            ["c.psd: layer \"glass\": fully transparent (no pixel has alpha > 0); skipped"]
        );
    }

    #[test]
    fn bad_channel_data_names_the_layer_and_channel() {
        let mut bytes = doc(
            2,
            1,
            &[L {
                rle: true,
                ..layer(b"arm", [0, 0, 1, 2], [255; 4])
            }],
        );
        // The first channel (7 bytes: compression, row length, run header, 2 bytes): its run of
        // 2 bytes becomes one of 3, past the row's end.
        let row = bytes.len() - 4 * 7 + 4;
        bytes[row] = 2;
        let err = import(&bytes).0.unwrap_err().to_string();
        assert_eq!(err, "c.psd: layer \"arm\": channel -1: row 0: a literal run past the row's end");
        // ZIP compression.
        let mut bytes = doc(1, 1, &[layer(b"arm", [0, 0, 1, 1], [255; 4])]);
        let first = bytes.len() - 4 * 3;
        bytes[first + 1] = 2;
        let err = import(&bytes).0.unwrap_err().to_string();
        assert!(err.contains("channel -1: ZIP-compressed channel data is not supported"), "{err}");
    }

    /// Found by fuzz/ (psd, after ~30 s): bounds with the bottom at -2³¹ under a top of 1 passed
    /// the canvas check and overflowed when the layer's height was taken.
    #[test]
    fn inverted_bounds_are_an_empty_layer_not_an_overflow() {
        let mut bytes = doc(2, 2, &[layer(b"arm", [1, 0, 1, 1], [255; 4])]);
        // The first record's bottom, after the header (26), four lengths (16), the count (2),
        // its top and left.
        bytes[52..56].copy_from_slice(&i32::MIN.to_be_bytes());
        let err = import(&bytes).0.unwrap_err().to_string();
        assert_eq!(err, "c.psd: layer \"arm\": fully transparent (no pixel has alpha > 0)");
    }

    #[test]
    fn unpaired_group_markers_are_errors() {
        let err = import(&doc(1, 1, &[layer(b"a", [0, 0, 1, 1], [255; 4]), group(b"g", 1)]))
            .0
            .unwrap_err();
        assert_eq!(err.to_string(), "c.psd: group \"g\" has no end marker");
        let err = import(&doc(1, 1, &[group(b"", 3), layer(b"a", [0, 0, 1, 1], [255; 4])]))
            .0
            .unwrap_err();
        assert_eq!(err.to_string(), "c.psd: layer record 1: a group's end with no group open");
    }

    #[test]
    fn a_canvas_past_the_limits_is_refused_before_any_layer_is_read() {
        let err = import(&doc(20000, 20000, &[])).0.unwrap_err().to_string();
        assert!(err.starts_with("c.psd: ") && err.contains("above the limit"), "{err}");
        let err = import(&doc(2, 2, &[])).0.unwrap_err().to_string();
        assert_eq!(
            err,
            "c.psd: no layers (the document holds only a flattened image: save it with its layers)"
        );
    }
}
