//! The one place that chooses Burn's CPU backend (DESIGN.md "Rules of the house").
//!
//! The backend is a cargo feature: `flex` (default), `ndarray` or `cpu`. `flex` was measured
//! fastest on our conv + FC training step (benches/README.md, `cargo bench --bench backend`).
//! Another backend (wgpu, cuda) is a one-line change in [`device`].

use burn::tensor::{Device, Tensor};

/// The concrete backend type behind [`device`], for the custom autodiff ops that must unwrap a
/// tensor's primitive (`render::burn_op`). Change it together with [`device`].
#[cfg(feature = "flex")]
pub type Inner = burn::backend::Flex;
/// The concrete backend type behind [`device`] (see the `flex` variant).
#[cfg(all(feature = "ndarray", not(feature = "flex")))]
pub type Inner = burn::backend::NdArray;
/// The concrete backend type behind [`device`] (see the `flex` variant).
#[cfg(all(feature = "cpu", not(any(feature = "flex", feature = "ndarray"))))]
pub type Inner = burn::backend::Cpu;

/// The device for inference and for kernels that do not need gradients.
pub fn device() -> Device {
    #[cfg(feature = "flex")]
    return Device::flex();
    #[cfg(all(feature = "ndarray", not(feature = "flex")))]
    #[allow(deprecated)] // measured 10× slower than flex; kept only for the comparison
    return Device::ndarray();
    #[cfg(all(feature = "cpu", not(any(feature = "flex", feature = "ndarray"))))]
    return Device::cpu();
    #[cfg(not(any(feature = "flex", feature = "ndarray", feature = "cpu")))]
    compile_error!("enable one Burn backend feature: flex, ndarray or cpu");
}

/// The device for training: [`device`] wrapped in autodiff.
pub fn train_device() -> Device {
    device().autodiff()
}

/// The name of the compiled-in backend, for logs and benchmark reports.
pub fn name() -> &'static str {
    if cfg!(feature = "flex") {
        "flex"
    } else if cfg!(feature = "ndarray") {
        "ndarray"
    } else {
        "cpu"
    }
}

/// The value of a one-element tensor (a loss) as f64; NaN if it cannot be read.
pub fn scalar(t: &Tensor<1>) -> f64 {
    t.clone()
        .into_data()
        .convert::<f64>()
        .try_to_vec::<f64>()
        .map_or(f64::NAN, |v| v[0])
}
