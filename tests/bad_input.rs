//! Every bad input of issue 2 gets exit code 1 and a message naming the file and the problem.

use crate::util::{puppet, write_label_character, write_layer_character};

fn build(dir: &std::path::Path, artwork: &str) -> crate::util::Run {
    puppet(dir, &["build", artwork, "-o", "out"])
}

#[test]
fn missing_artwork_folder() {
    let tmp = tempfile::tempdir().unwrap();
    build(tmp.path(), "nowhere").assert_error(&["nowhere: no such file or folder"]);
}

#[test]
fn missing_layer_file() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    std::fs::remove_file(dir.join("arm.png")).unwrap();
    build(tmp.path(), "c").assert_error(&["c/arm.png", "No such file"]);
}

#[test]
fn unreadable_layer_png() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    std::fs::write(dir.join("head.png"), b"\x89PNG garbage").unwrap();
    build(tmp.path(), "c").assert_error(&["c/head.png", "cannot decode image"]);
}

#[test]
fn layers_of_different_sizes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    image::RgbaImage::from_pixel(32, 40, image::Rgba([1, 2, 3, 255]))
        .save(dir.join("arm.png"))
        .unwrap();
    build(tmp.path(), "c").assert_error(&["c/arm.png", "layer \"arm\"", "32×40, expected 64×64"]);
}

#[test]
fn fully_transparent_layer() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    image::RgbaImage::new(64, 64).save(dir.join("head.png")).unwrap();
    build(tmp.path(), "c").assert_error(&["c/head.png", "layer \"head\"", "fully transparent"]);
}

#[test]
fn label_colour_not_in_legend() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_label_character(&tmp.path().join("c"));
    let mut map = image::open(dir.join("labels.png")).unwrap().to_rgba8();
    map.put_pixel(30, 40, image::Rgba([10, 20, 30, 255]));
    map.save(dir.join("labels.png")).unwrap();
    build(tmp.path(), "c").assert_error(&["c/labels.png", "not in the legend", "#0a141e (1 px, first at (30, 40))"]);
}

#[test]
fn legend_colour_absent_from_map() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_label_character(&tmp.path().join("c"));
    let toml = std::fs::read_to_string(dir.join("character.toml")).unwrap();
    std::fs::write(
        dir.join("character.toml"),
        format!("{toml}[[layer]]\nname = \"tail\"\ncolor = \"#123456\"\n"),
    )
    .unwrap();
    build(tmp.path(), "c").assert_error(&["c/labels.png", "layer \"tail\"", "#123456 does not appear in the label map"]);
}

#[test]
fn unknown_key_in_character_toml() {
    let tmp = tempfile::tempdir().unwrap();
    write_layer_character(&tmp.path().join("c"), "scale = 2");
    build(tmp.path(), "c").assert_error(&["c/character.toml", "unknown field `scale`"]);
}

#[test]
fn no_root_body_layer() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    let toml = std::fs::read_to_string(dir.join("character.toml"))
        .unwrap()
        .replace("root = \"torso\"\n", "");
    std::fs::write(dir.join("character.toml"), toml).unwrap();
    build(tmp.path(), "c").assert_error(&["c/character.toml", "no root body layer"]);
}

#[test]
fn duplicate_layer_names() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    let toml = std::fs::read_to_string(dir.join("character.toml")).unwrap();
    std::fs::write(
        dir.join("character.toml"),
        format!("{toml}[[layer]]\nname = \"head\"\nfile = \"arm.png\"\n"),
    )
    .unwrap();
    build(tmp.path(), "c").assert_error(&["c/character.toml", "layer \"head\": duplicate layer name"]);
}

#[test]
fn ora_that_is_not_a_zip() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("bad.ora"), b"this is not a zip file at all").unwrap();
    build(tmp.path(), "bad.ora").assert_error(&["bad.ora", "not a valid OpenRaster zip"]);
}

/// Writes a zip with the given (name, bytes) entries.
fn write_zip(path: &std::path::Path, entries: &[(&str, &[u8])]) {
    use std::io::Write;
    let mut zip = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    for (name, bytes) in entries {
        zip.start_file(*name, zip::write::SimpleFileOptions::default()).unwrap();
        zip.write_all(bytes).unwrap();
    }
    zip.finish().unwrap();
}

#[test]
fn ora_without_stack_xml() {
    let tmp = tempfile::tempdir().unwrap();
    write_zip(&tmp.path().join("nostack.ora"), &[("mimetype", b"image/openraster")]);
    build(tmp.path(), "nostack.ora").assert_error(&["nostack.ora", "no stack.xml in the archive"]);
}

#[test]
fn ora_layer_referenced_but_absent() {
    let tmp = tempfile::tempdir().unwrap();
    let stack = br#"<image w="8" h="8"><stack><layer name="arm" src="data/arm.png"/></stack></image>"#;
    write_zip(
        &tmp.path().join("absent.ora"),
        &[("mimetype", b"image/openraster"), ("stack.xml", stack)],
    );
    build(tmp.path(), "absent.ora").assert_error(&["absent.ora", "layer \"arm\"", "\"data/arm.png\", which is not in the archive"]);
}

#[test]
fn ora_with_malformed_stack_xml() {
    let tmp = tempfile::tempdir().unwrap();
    let stack = br#"<image w="8" h="8"><stack><layer name="arm" src="a.png"></stack></image>"#;
    write_zip(
        &tmp.path().join("malformed.ora"),
        &[("mimetype", b"image/openraster"), ("stack.xml", stack)],
    );
    build(tmp.path(), "malformed.ora").assert_error(&["malformed.ora", "stack.xml: malformed XML"]);
}

#[test]
fn part_too_small_to_mesh_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    // A single opaque pixel, far from everything.
    let mut speck = image::RgbaImage::new(64, 64);
    speck.put_pixel(3, 60, image::Rgba([0, 0, 0, 255]));
    speck.save(dir.join("speck.png")).unwrap();
    let toml = std::fs::read_to_string(dir.join("character.toml")).unwrap();
    std::fs::write(
        dir.join("character.toml"),
        format!("{toml}[[layer]]\nname = \"speck\"\nfile = \"speck.png\"\n"),
    )
    .unwrap();
    build(tmp.path(), "c").assert_error(&["c/character.toml", "layer \"speck\"", "too small"]);
}

#[test]
fn puppet_from_a_future_schema() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::create_dir(tmp.path().join("p")).unwrap();
    std::fs::write(tmp.path().join("p/puppet.json"), r#"{"schema": 99, "layers": []}"#).unwrap();
    puppet(tmp.path(), &["info", "p"]).assert_error(&["p/puppet.json", "schema version 99 is newer"]);
}

#[test]
fn puppet_json_that_is_not_json() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::create_dir(tmp.path().join("p")).unwrap();
    std::fs::write(tmp.path().join("p/puppet.json"), "{ nope").unwrap();
    puppet(tmp.path(), &["info", "p"]).assert_error(&["p/puppet.json", "not a puppet file"]);
}

/// Issue 17: the bad documents psd-tools wrote (data/tools/make_psd.sh), each a clear error
/// naming the file and what is wrong.
#[test]
fn psd_that_is_not_8_bit_rgb_or_has_no_layers_or_a_layer_past_the_canvas() {
    let tmp = tempfile::tempdir().unwrap();
    for (file, expected) in [
        ("depth16.psd", "16-bit channels: only 8 bits per channel are supported"),
        ("depth32.psd", "32-bit channels: only 8 bits per channel are supported"),
        ("cmyk.psd", "CMYK colour mode (4): only RGB documents are supported"),
        ("grayscale.psd", "grayscale colour mode (1): only RGB documents are supported"),
        ("no_layers.psd", "no layers (the document holds only a flattened image"),
        (
            "past_canvas.psd",
            "layer \"part\": its bounds, x 3..5 and y 0..2, extend past the 4×4 canvas",
        ),
    ] {
        std::fs::copy(crate::util::repo().join("data/psd/bad").join(file), tmp.path().join(file)).unwrap();
        build(tmp.path(), file).assert_error(&[file, expected]);
    }
}

/// Issue 17: a .psd cut short anywhere in its header or layers says it is truncated and where.
#[test]
fn psd_truncated() {
    let tmp = tempfile::tempdir().unwrap();
    let whole = std::fs::read(crate::util::repo().join("data/psd/robot_krita.psd")).unwrap();
    for (len, expected) in [
        (20, "truncated: the width needs 4 bytes at offset 18, but the file ends at 20"),
        (whole.len() / 2, "truncated: the layer and mask information needs"),
    ] {
        std::fs::write(tmp.path().join("cut.psd"), &whole[..len]).unwrap();
        build(tmp.path(), "cut.psd").assert_error(&["cut.psd", expected]);
    }
    std::fs::write(tmp.path().join("png.psd"), b"\x89PNG\r\n\x1a\n").unwrap();
    build(tmp.path(), "png.psd").assert_error(&["png.psd", "not a Photoshop document (no 8BPS signature)"]);
}
