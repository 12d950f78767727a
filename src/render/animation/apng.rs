//! Animated PNG (APNG): every frame in full 8-bit straight alpha, each replacing the last
//! (blend "source", dispose "none"), looping forever — what browsers play and engines import
//! where a GIF's 1-bit alpha would cut soft edges.

use std::io::BufWriter;
use std::path::{Path, PathBuf};

use super::stream::{FileSink, TempFile};
use crate::error::{Error, Result};
use crate::picture::Picture;

/// An APNG being written; it must know its frame count before the first frame.
pub(super) struct ApngStream {
    writer: png::Writer<BufWriter<FileSink>>,
    file: TempFile,
}

impl ApngStream {
    /// # Errors
    /// [`Error::Setting`] for a frame time past 65,535 ms (APNG stores it in 16 bits);
    /// [`Error::Io`] / [`Error::Image`] if the file cannot be started.
    pub(super) fn create(path: &Path, size: (u32, u32), frames: usize, delay_ms: u32) -> Result<Self> {
        let delay =
            u16::try_from(delay_ms.max(1)).map_err(|_| Error::setting("APNG frame time", format!("{delay_ms} ms"), "at most 65535 ms"))?;
        let frames = u32::try_from(frames).map_err(|_| Error::setting("APNG frames", frames, "at most 2³² − 1"))?;
        let file = TempFile::create(path)?;
        let failed = |e: png::EncodingError| Error::image(path, format!("cannot encode APNG: {e}"));
        let mut encoder = png::Encoder::new(BufWriter::new(file.sink()), size.0, size.1);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_animated(frames, 0).map_err(failed)?;
        encoder.set_frame_delay(delay, 1000).map_err(failed)?;
        let writer = encoder.write_header().map_err(failed)?;
        Ok(ApngStream { writer, file })
    }

    pub(super) fn push(&mut self, frame: &Picture) -> Result<()> {
        self.writer
            .write_image_data(frame.to_rgba8().as_raw())
            .map_err(|e| Error::image(self.file.path(), format!("cannot encode APNG: {e}")))
    }

    pub(super) fn finish(self) -> Result<PathBuf> {
        let ApngStream { writer, file } = self;
        // Writes the end chunk and flushes the buffer.
        writer
            .finish()
            .map_err(|e| Error::image(file.path(), format!("cannot finish APNG: {e}")))?;
        file.commit()
    }
}
