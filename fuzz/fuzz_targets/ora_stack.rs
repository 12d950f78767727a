//! An OpenRaster `stack.xml`, zipped by the harness with two small layer PNGs (`a.png` 8×8
//! opaque, `b.png` 4×4 half transparent) so every input reaches the XML parser and the layer
//! placement: an accepted import keeps `common::check_artwork`.
#![no_main]

use std::io::{Cursor, Write};
use std::path::Path;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use puppet::picture::Picture;
use puppet::puppet::artwork::ImportOptions;
use puppet::puppet::ora;

#[path = "common.rs"]
mod common;

/// The two layer PNGs, encoded once.
fn layers() -> &'static [(&'static str, Vec<u8>); 2] {
    static LAYERS: OnceLock<[(&str, Vec<u8>); 2]> = OnceLock::new();
    LAYERS.get_or_init(|| {
        let png = |p: Picture| p.png_bytes(Path::new("fuzz")).expect("encodes");
        [
            ("a.png", png(Picture::filled(8, 8, [1.0, 0.0, 0.0, 1.0]))),
            ("b.png", png(Picture::filled(4, 4, [0.0, 0.0, 1.0, 0.5]))),
        ]
    })
}

fuzz_target!(|data: &[u8]| {
    let mut bytes = Vec::new();
    {
        let mut zip = zip::ZipWriter::new(Cursor::new(&mut bytes));
        let stored = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
        zip.start_file("mimetype", stored).expect("in memory");
        zip.write_all(b"image/openraster").expect("in memory");
        zip.start_file("stack.xml", stored).expect("in memory");
        zip.write_all(data).expect("in memory");
        for (name, png) in layers() {
            zip.start_file(*name, stored).expect("in memory");
            zip.write_all(png).expect("in memory");
        }
        zip.finish().expect("in memory");
    }
    if let Ok(art) = ora::from_reader(Cursor::new(bytes), Path::new("fuzz/stack.ora"), &ImportOptions::default(), &puppet::progress::Silent) {
        common::check_artwork(&art);
    }
});
