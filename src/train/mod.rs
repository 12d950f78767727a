//! Training the deformation network (neural-puppet.md §3.2): the optimiser.

pub mod optim;
