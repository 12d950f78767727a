//! A drag pin: what a person grabs on the character and where they put it ([`super::pose`]
//! optimises a pose to follow pins; [`super::pin_overlay`] draws them).

/// One pin: the point the user grabbed (`from`, on the character in the input frame) and where
/// it should go (`to`), both in frame pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pin {
    /// The grabbed point, frame pixels.
    pub from: [f32; 2],
    /// Its target, frame pixels.
    pub to: [f32; 2],
}
