//! OpenRaster (`.ora`) import: a zip holding `mimetype`, `stack.xml` and one PNG per layer —
//! what Krita, GIMP and MyPaint export (spec: openraster.org, "Stack").
//!
//! `stack.xml` lists layers top (front) first; we reverse to our back → front order. Each layer
//! PNG is placed at its `x`, `y` offset on an image-sized canvas and multiplied by its `opacity`.
//! Hidden layers (`visibility="hidden"`) are skipped. Layers inside a stack named `accessories`
//! are accessories; all others are body parts. The root is the body layer with the most opaque
//! pixels. Every overlapping pair of layers is joined. A `character.toml` beside the file may say
//! otherwise ([`super::character::LayeredOverrides`]).
//!
//! A zip can declare anything: the archive itself may be at most [`max_file_bytes`] long (the
//! zip index in memory grows with it), `stack.xml` is read to at most [`MAX_STACK_XML`] bytes,
//! each layer PNG to at most [`MAX_LAYER_ENTRY`] bytes however small its compressed form, and
//! the canvas and layer count are checked against [`ImportOptions`] before any layer is decoded.

use std::io::{Read, Seek};
use std::path::Path;

use quick_xml::events::Event;

use super::layers::{assemble, place, ArtLayer, Artwork, ImportOptions};
use super::LayerKind;
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::user_file;

/// The most bytes `stack.xml` may inflate to (a real one is a few kilobytes).
pub const MAX_STACK_XML: u64 = 4 << 20;
/// The most bytes one layer's PNG may inflate to (a 16-bit RGBA PNG of the largest canvas,
/// stored uncompressed, is 128 MB).
pub const MAX_LAYER_ENTRY: u64 = 144 << 20;

/// One `<layer>` element of `stack.xml`.
struct StackLayer {
    name: String,
    src: String,
    x: i64,
    y: i64,
    opacity: f32,
    accessory: bool,
}

/// The longest `.ora` file read: every layer's pixels at the most the import allows
/// ([`ImportOptions::max_total_pixels`]) stored as uncompressed 16-bit PNGs, plus one largest image
/// file for the merged image editors add — 656 MiB by default (real files are far smaller:
/// `data/kenney/robot/robot.ora`, nine layers of 96×128, is 49 KB).
pub fn max_file_bytes(opts: &ImportOptions) -> u64 {
    opts.max_total_pixels.saturating_mul(8).saturating_add(opts.image.max_file_bytes())
}

/// Reads a `.ora` file.
///
/// # Errors
/// [`Error::Io`] if unreadable; [`Error::Limit`] if it is longer than [`max_file_bytes`]; as
/// [`from_reader`] for its contents.
pub fn load(path: &Path, opts: &ImportOptions, progress: &dyn Progress) -> Result<Artwork> {
    from_reader(user_file::open(path, max_file_bytes(opts))?, path, opts, progress)
}

/// Reads the bytes of a `.ora` archive from `reader`; `path` names it in errors and gives the
/// character its name.
///
/// # Errors
/// [`Error::Format`] for a bad zip, a missing or malformed `stack.xml`, or a layer whose PNG is
/// absent; [`Error::Layer`] for an undecodable or fully transparent layer; [`Error::Limit`] for a
/// canvas, layer count or entry past the limits.
pub fn from_reader(reader: impl Read + Seek, path: &Path, opts: &ImportOptions, progress: &dyn Progress) -> Result<Artwork> {
    let mut zip = zip::ZipArchive::new(reader).map_err(|e| Error::format(path, format!("not a valid OpenRaster zip: {e}")))?;
    let stack_xml = read_entry(&mut zip, "stack.xml", MAX_STACK_XML, path)?
        .ok_or_else(|| Error::format(path, "no stack.xml in the archive (not an OpenRaster file?)"))?;
    let stack_xml = String::from_utf8(stack_xml).map_err(|_| Error::format(path, "stack.xml is not UTF-8"))?;
    let (width, height, entries) = parse_stack(&stack_xml).map_err(|p| Error::format(path, format!("stack.xml: {p}")))?;
    opts.check(entries.len(), width, height)
        .map_err(|e| e.with_key("stack.xml").with_path(path))?;
    let mut layers = Vec::new();
    let mut problems = Vec::new();
    for entry in entries.iter().rev() {
        let bytes = match read_entry(&mut zip, &entry.src, MAX_LAYER_ENTRY, path) {
            Ok(Some(b)) => b,
            Ok(None) => {
                problems.push(Error::layer(
                    path,
                    &entry.name,
                    format!("stack.xml references {:?}, which is not in the archive", entry.src),
                ));
                continue;
            }
            Err(e) => {
                problems.push(e);
                continue;
            }
        };
        let inner = path.join(&entry.src);
        match Picture::decode_within(&bytes, &inner, &opts.image) {
            Ok(pic) => {
                let kind = if entry.accessory { LayerKind::Accessory } else { LayerKind::Body };
                layers.push(ArtLayer {
                    name: entry.name.clone(),
                    kind,
                    picture: place(&pic, [entry.x, entry.y], entry.opacity, width, height),
                });
            }
            Err(e) => problems.push(Error::layer(path, &entry.name, e.to_string())),
        }
    }
    assemble(path, layers, problems, progress)
}

/// The entry `name` inflated, at most `limit` bytes; `None` if the archive has no such entry.
fn read_entry(zip: &mut zip::ZipArchive<impl Read + Seek>, name: &str, limit: u64, path: &Path) -> Result<Option<Vec<u8>>> {
    let entry = match zip.by_name(name) {
        Ok(entry) => entry,
        Err(zip::result::ZipError::FileNotFound) => return Ok(None),
        Err(e) => return Err(Error::format(path, format!("{name}: cannot unzip: {e}"))),
    };
    let mut bytes = Vec::new();
    // The declared size can lie; read one byte past the limit to know it was exceeded.
    entry
        .take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::format(path, format!("{name}: cannot unzip: {e}")))?;
    if bytes.len() as u64 > limit {
        return Err(Error::limit(format!("{name} inflated"), bytes.len() as u64, limit, "bytes").with_path(path));
    }
    Ok(Some(bytes))
}

/// Parses `stack.xml` into the image size and its layers, top first.
fn parse_stack(xml: &str) -> std::result::Result<(u32, u32, Vec<StackLayer>), String> {
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut size = None;
    let mut layers = Vec::new();
    // Names of the enclosing <stack> elements, to find the "accessories" group.
    let mut stacks: Vec<String> = Vec::new();
    loop {
        let event = reader
            .read_event()
            .map_err(|e| format!("malformed XML at byte {}: {e}", reader.buffer_position()))?;
        let (element, is_empty) = match &event {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(e) if e.name().as_ref() == b"stack" => {
                stacks.pop();
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        let mut attrs = std::collections::HashMap::new();
        for a in element.attributes() {
            let a = a.map_err(|e| format!("bad attribute: {e}"))?;
            let value = a.unescape_value().map_err(|e| format!("bad attribute value: {e}"))?.into_owned();
            attrs.insert(String::from_utf8_lossy(a.key.as_ref()).into_owned(), value);
        }
        // Finite only: a NaN opacity would make every pixel's alpha NaN, a NaN size a 0-wide canvas.
        let number = |key: &str, default: f64| -> std::result::Result<f64, String> {
            attrs.get(key).map_or(Ok(default), |v| {
                v.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|n| n.is_finite())
                    .ok_or_else(|| format!("{key}={v:?} is not a finite number"))
            })
        };
        match element.name().as_ref() {
            b"image" => {
                let (w, h) = (number("w", 0.0)?, number("h", 0.0)?);
                if w < 1.0 || h < 1.0 {
                    return Err("<image> needs positive w and h".into());
                }
                size = Some((w as u32, h as u32));
            }
            b"stack" if !is_empty => stacks.push(attrs.get("name").cloned().unwrap_or_default()),
            b"layer" => {
                if attrs.get("visibility").is_some_and(|v| v == "hidden") {
                    continue;
                }
                let src = attrs.get("src").cloned().ok_or("a <layer> has no src")?;
                let name = attrs.get("name").cloned().unwrap_or_else(|| src.clone());
                let accessory = stacks.iter().any(|s| s.eq_ignore_ascii_case("accessories"));
                layers.push(StackLayer {
                    name,
                    src,
                    x: number("x", 0.0)? as i64,
                    y: number("y", 0.0)? as i64,
                    opacity: number("opacity", 1.0)?.clamp(0.0, 1.0) as f32,
                    accessory,
                });
            }
            _ => {}
        }
    }
    let (w, h) = size.ok_or("no <image> element")?;
    if layers.is_empty() {
        return Err("no visible <layer> elements".into());
    }
    Ok((w, h, layers))
}

/// Writes artwork as a `.ora` (all layers full-size, back → front reversed to top-first), for
/// tests and for exporting a label-map character to an editor.
///
/// # Errors
/// [`Error::Io`] or [`Error::Image`] naming `path`.
pub fn save(artwork: &Artwork, path: &Path) -> Result<()> {
    use std::io::Write;
    let (w, h) = artwork.size();
    let mut bytes = Vec::new();
    {
        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(&mut bytes));
        let stored = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
        let zip_err = |e: zip::result::ZipError| Error::format(path, format!("cannot write zip: {e}"));
        let io_err = |e: std::io::Error| Error::io(path, e);
        zip.start_file("mimetype", stored).map_err(zip_err)?;
        zip.write_all(b"image/openraster").map_err(io_err)?;
        let mut xml = format!("<?xml version='1.0' encoding='UTF-8'?>\n<image version=\"0.0.3\" w=\"{w}\" h=\"{h}\">\n<stack>\n");
        for (i, layer) in artwork.layers.iter().enumerate().rev() {
            let src = format!("data/layer{i}.png");
            let name = quick_xml::escape::escape(layer.name.as_str());
            xml.push_str(&format!(
                "<layer name=\"{name}\" src=\"{src}\" x=\"0\" y=\"0\" opacity=\"1.0\" visibility=\"visible\"/>\n"
            ));
            let mut png = Vec::new();
            layer
                .picture
                .to_rgba8()
                .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .map_err(|e| Error::Image {
                    path: path.to_path_buf(),
                    problem: e.to_string(),
                })?;
            zip.start_file(src, stored).map_err(zip_err)?;
            zip.write_all(&png).map_err(io_err)?;
        }
        xml.push_str("</stack>\n</image>\n");
        zip.start_file("stack.xml", stored).map_err(zip_err)?;
        zip.write_all(xml.as_bytes()).map_err(io_err)?;
        zip.finish().map_err(zip_err)?;
    }
    crate::atomic_file::write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use std::io::{Cursor, Write};

    use super::*;

    /// A `.ora` in memory: `stack_xml` and one 2×2 opaque layer `a.png`.
    fn archive(stack_xml: &[u8]) -> Vec<u8> {
        let mut bytes = Vec::new();
        let mut zip = zip::ZipWriter::new(Cursor::new(&mut bytes));
        let stored = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
        zip.start_file("stack.xml", stored).unwrap();
        zip.write_all(stack_xml).unwrap();
        zip.start_file("a.png", stored).unwrap();
        zip.write_all(&Picture::filled(2, 2, [1.0; 4]).png_bytes(Path::new("a.png")).unwrap())
            .unwrap();
        zip.finish().unwrap();
        bytes
    }

    fn import(stack_xml: &str) -> Result<Artwork> {
        from_reader(
            Cursor::new(archive(stack_xml.as_bytes())),
            Path::new("c.ora"),
            &ImportOptions::default(),
            &crate::progress::Silent,
        )
    }

    #[test]
    fn a_layer_reads_at_its_offset() {
        let art = import(r#"<image w="4" h="3"><stack><layer name="a" src="a.png" x="1" y="1"/></stack></image>"#).unwrap();
        assert_eq!(art.layers.len(), 1);
        let opaque: Vec<usize> = (0..12).filter(|&i| art.layers[0].picture.pixels[i][3] == 1.0).collect();
        assert_eq!(opaque, [5, 6, 9, 10]);
    }

    /// Found by fuzz/ (ora_stack, minimised): an offset beyond i64 saturated to `i64::MAX` and
    /// overflowed when the layer was placed.
    #[test]
    fn an_offset_far_off_the_canvas_is_a_transparent_layer_not_an_overflow() {
        for x in ["2666666666666666666666666666666666666666666664", "-1e300"] {
            let xml = format!(r#"<image w="8" h="8"><stack><layer name="torso" src="a.png" x="{x}"/></stack></image>"#);
            let err = import(&xml).unwrap_err().to_string();
            assert_eq!(err, "c.ora: layer \"torso\": fully transparent (no pixel has alpha > 0)");
        }
    }

    /// Found while writing the ora_stack target (`common::check_layers`, by hand, not by the
    /// fuzzer): `opacity="nan"` gave a layer whose alpha was NaN everywhere.
    #[test]
    fn a_number_that_is_not_finite_is_an_error_naming_the_attribute() {
        let layer = |attrs: &str| format!(r#"<image w="8" h="8"><stack><layer src="a.png" {attrs}/></stack></image>"#);
        for (xml, problem) in [
            (layer(r#"opacity="nan""#), r#"opacity="nan" is not a finite number"#),
            (layer(r#"x="inf""#), r#"x="inf" is not a finite number"#),
            (
                r#"<image w="NaN" h="8"><stack><layer src="a.png"/></stack></image>"#.to_string(),
                r#"w="NaN" is not a finite number"#,
            ),
        ] {
            let err = import(&xml).unwrap_err().to_string();
            assert_eq!(err, format!("c.ora: stack.xml: {problem}"));
        }
    }
}
