//! The allocator of the `puppet` binary and of the training benchmarks (included with
//! `#[path]`, not part of the library, which forbids `unsafe`).
//!
//! Burn allocates and frees a large buffer per tensor operation; glibc's malloc returns big
//! blocks to the OS and maps them again each time (page faults, zeroing), mimalloc keeps them.
//! Measured in benches/README.md "backend".

#[cfg(feature = "mimalloc")]
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Tells mimalloc never to return freed memory to the OS. A training step frees and allocates
/// the same ~134 MB gradient buffers every time; with mimalloc's default purge delay each of them
/// comes back as fresh pages that the kernel zeroes on first touch (a quarter of a step in the
/// profile, benches/README.md "backend"). The cost is that the process keeps its peak memory.
/// Does nothing without the `mimalloc` feature.
#[allow(unsafe_code)] // one foreign call, justified below
pub fn keep_freed_memory() {
    #[cfg(feature = "mimalloc")]
    {
        // `mi_option_purge_delay` in mimalloc v3's `enum mi_option_e` (mimalloc.h), which
        // libmimalloc-sys 0.1.49 does not name; -1 means "never purge".
        const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;
        // SAFETY: mi_option_set only stores an integer in mimalloc's option table; it is
        // thread-safe and valid at any time, and no pointer crosses the call.
        unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) };
    }
}
