//! The GPU chassis, dimension-free: what every engine's GPU backend stands on (DESIGN.md §1–3).
//!
//! - `device`: adapters, device set-up with the adapter's own limits, bounded waits, whether a
//!   buffer fits one binding (`check_fits`).
//! - `real`: the kernel precision as a sealed Rust type (`Real`: f32 or f64) and `gpu_struct!`,
//!   which defines a Pod struct generic over it with the field offsets naga checks.
//! - `wgsl`: the pieces of a WGSL prelude every engine's kernels share (workgroup size,
//!   dispatch grids) and naga validation.
//! - `stream`: the streaming-kernel yardstick of the card's memory bandwidth
//!   (`shaders/stream_copy.wgsl`) and the copy-engine figure beside it.
//! - `profile`: each kernel's time per cycle (pass timestamps, or isolated dispatches) and the
//!   byte model's row, for any engine's bench (`udec::gpu::profile`, `d3::gpu::profile`).
//!
//! The 2D engine's kernels, buffers and run are in `udec::gpu`.

pub mod device;
pub mod profile;
pub mod real;
pub mod stream;
pub mod wgsl;

pub use device::{list_adapters, matching_adapters, AdapterChoice, AdapterSummary, GpuApi, GpuDevice};
pub use real::{Real, StructLayout};

/// Kernel precision (`--precision`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Precision {
    #[default]
    F32,
    F64,
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        })
    }
}

/// Why the GPU backend could not start or went wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter: {0}")]
    NoAdapter(String),
    #[error("--precision f64 needs an adapter with SHADER_F64, and {0}, without it; use --precision f32 or a Vulkan adapter")]
    NoF64(String),
    #[error("GPU set-up: {0}")]
    Setup(String),
    /// The model does not fit the adapter or the kernel precision: a buffer past the binding
    /// limit (`device::check_fits`), a value outside f32's range (`run::representable`).
    #[error("GPU set-up: {0}")]
    DoesNotFit(String),
    #[error("GPU shader: {0}")]
    Shader(String),
    #[error("GPU device: {0}")]
    Device(String),
}
