//! Animated GIF. GIF has a 256-colour palette and 1-bit transparency: on a transparent
//! background a pixel is either drawn (alpha ≥ ½, in its straight colour — no matte, so no halo
//! on whatever page shows it) or transparent; on a colour, frames are composited on it first.
//! Frames are quantised one by one by the `image` crate (NeuQuant), each replacing the last.

use std::io::BufWriter;
use std::path::PathBuf;

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame};

use super::flatten;
use super::stream::{FileSink, TempFile};
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::render::Background;

/// A GIF being written.
pub(super) struct GifStream {
    encoder: GifEncoder<BufWriter<FileSink>>,
    file: TempFile,
    delay: Delay,
    background: Background,
}

impl GifStream {
    pub(super) fn create(path: &std::path::Path, delay_ms: u32, background: Background) -> Result<Self> {
        let file = TempFile::create(path)?;
        // Speed 1: NeuQuant learns the palette from every pixel. At 10 it samples a tenth and,
        // on a rendered robot, lost the small yellow eye (drawn pink); frames here are small.
        let mut encoder = GifEncoder::new_with_speed(BufWriter::new(file.sink()), 1);
        encoder
            .set_repeat(Repeat::Infinite)
            .map_err(|e| Error::image(path, format!("cannot encode GIF: {e}")))?;
        Ok(GifStream {
            encoder,
            file,
            delay: Delay::from_numer_denom_ms(delay_ms.max(1), 1),
            background,
        })
    }

    pub(super) fn push(&mut self, frame: &Picture) -> Result<()> {
        let pixels = match self.background {
            Background::Colour(c) => flatten(frame, c),
            Background::Transparent => frame.mapped(|[r, g, b, a]| if a >= 0.5 { [r, g, b, 1.0] } else { [0.0; 4] }),
        };
        let frame = Frame::from_parts(pixels.to_rgba8(), 0, 0, self.delay);
        self.encoder
            .encode_frame(frame)
            .map_err(|e| Error::image(self.file.path(), format!("cannot encode GIF: {e}")))
    }

    pub(super) fn finish(self) -> Result<PathBuf> {
        let GifStream { encoder, file, .. } = self;
        // Dropping the encoder writes the GIF trailer and flushes the buffer; a write that
        // failed then is kept by the sink, since a drop cannot report it.
        drop(encoder);
        file.commit()
    }
}
