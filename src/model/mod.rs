//! Burn modules (neural-puppet.md §3.2): the deformation network that maps a frame to the
//! template's vertex positions. Losses and training live in `train`; this module holds only
//! modules and their configs.

pub mod deformation;
