//! What `blockdem bench` asks of the GPU beyond running cycles: the time of each kernel stage, the
//! adapter's copy bandwidth, and the bytes each stage must move per cycle (the roofline model).
//!
//! - Stage times: with `TIMESTAMP_QUERY` (requested at device set-up when the adapter has it) each
//!   stage's compute pass of a normal cycle writes a timestamp at its start and end; without it,
//!   each stage is dispatched alone, many times in one submission, and timed on the host
//!   (`BLOCKDEM_STAGE_TIMING=isolated` asks for this even where timestamps exist). Either
//!   way this runs on the state the last `run` left on the device and changes it; the next `run`
//!   uploads the whole model again, so nothing leaks into a simulation.
//! - Bandwidth, two ways, bytes read + bytes written per second (the same count the byte model
//!   uses): the yardstick, a streaming copy kernel (`shaders/stream_copy.wgsl`) over buffers far
//!   larger than any cache at several sizes, the best of several runs ([`stream_bandwidth`]); and
//!   a large `copy_buffer_to_buffer` ([`copy_bandwidth`]), which on NVIDIA's Vulkan driver goes
//!   through a copy engine at a quarter of what a kernel reaches (846 GB/s on an H100 whose HBM3
//!   gives 3.35 TB/s), so a roofline against it flattered the cycle about fourfold.
//! - Bytes per cycle: the compulsory traffic of each kernel, from the Pod struct sizes and the
//!   live counts: every struct a kernel reads counts once per stage (as if each were fetched
//!   from memory once and then cached), and the fields it stores count once. A GPU fetches
//!   whole 32-byte sectors, and these structs are 40–200 bytes with their fields read all over
//!   them, so whole structs are counted as read; stores count the fields a stage writes every
//!   cycle (a contact's four changing state fields are one sector in f64).

use super::layout::{Block, Contact, ContactForce, Corner, Flags, Material, Params, Real};
use super::{Engine, GpuBackend, GpuDevice, GpuError};
use crate::gpu::profile::{time_passes, Pass};
pub use crate::gpu::profile::{DeviceProfile, StageBytes};
pub use crate::gpu::stream::{copy_bandwidth, stream_bandwidth, StreamBandwidth};

/// The compulsory traffic of each kernel per cycle in precision `R`, for `nb` blocks, `nc`
/// corners and `nk` contacts (the buffers each kernel touches are in its WGSL file).
pub fn bytes_per_cycle<R: Real>(nb: usize, nc: usize, nk: usize, materials: usize) -> Vec<StageBytes> {
    let (b, c, k) = (std::mem::size_of::<Block<R>>() as u64, std::mem::size_of::<Corner<R>>() as u64, std::mem::size_of::<Contact<R>>() as u64);
    let (m, r, u) = (std::mem::size_of::<Material<R>>() as u64, std::mem::size_of::<R>() as u64, 4u64);
    let f = std::mem::size_of::<ContactForce<R>>() as u64;
    let (nb, nc, nk, nm) = (nb as u64, nc as u64, nk as u64, materials as u64);
    let params = std::mem::size_of::<Params<R>>() as u64;
    let flags = std::mem::size_of::<Flags>() as u64;
    vec![
        // With stage 6 first: each block read whole, its adjacency list (offsets, two entries per
        // contact) and each contact's gather record (read by both its blocks, so fetched twice
        // unless cached). Its 11 changed fields stored (velocities, centroid pairs, rotation,
        // update distance, works; the force sums are not); with stage 2, each of its corners
        // read whole and its placed corner and circle centre (4 fields) stored.
        StageBytes { stage: "law_of_motion", read: b * nb + u * (nb + 1) + u * 2 * nk + f * nk + c * nc + params, written: 11 * r * nb + 4 * r * nc },
        // Each contact read whole, the 4 state fields every cycle changes stored (gap, normal and
        // shear force, shear displacement; the rest only on the rare cycle it changes) and its
        // gather record stored; both blocks, block 1's corner and block 2's corners read (every
        // corner and block once); the material table.
        StageBytes { stage: "contact_forces", read: k * nk + c * nc + b * nb + m * nm + params, written: 4 * r * nk + f * nk },
        StageBytes { stage: "end_cycle", read: flags, written: flags },
    ]
}

impl<R: Real> Engine<R> {
    fn profile_stages(&mut self, cycles: u32) -> Result<DeviceProfile, GpuError> {
        // The profiled cycles move the device's state on: the next run must start from the model.
        self.resumable = false;
        let (Some(buffers), Some(_)) = (self.buffers.as_ref(), self.bind_groups.as_ref()) else {
            return Err(GpuError::Setup("profile_stages needs a run first (no state on the device)".into()));
        };
        let dev = &self.dev;
        let stages = self.stages(false);
        dev.queue.write_buffer(&buffers.flags, 0, bytemuck::bytes_of(&Flags::cleared()));
        // The cycle's own gather (fixed blocks skipped), whatever pass ran last.
        self.write_pass_params(false);
        let passes: Vec<Pass> = stages.iter().map(|d| Pass { label: d.label, pipeline: d.pipeline, bind_group: d.bind_group, grid: d.grid }).collect();
        time_passes(
            dev,
            &passes,
            cycles,
            // A halt raised by end_cycle (stage 7 due) would idle the later cycles: clear it.
            &|enc| enc.clear_buffer(&buffers.flags, 0, None),
            &|| dev.queue.write_buffer(&buffers.flags, 0, bytemuck::bytes_of(&Flags::cleared())),
        )
    }
}

impl GpuBackend {
    fn device(&self) -> &GpuDevice {
        on_engine!(&self.engine, e => &e.dev)
    }

    /// Whether the device writes pass timestamps (stage times are then measured inside cycles).
    pub fn has_timestamps(&self) -> bool {
        crate::gpu::profile::has_timestamps(self.device())
    }

    /// The device time of each kernel stage over `cycles` cycles (or dispatches), on the state the
    /// last `run` left on the device (see the module doc; the next `run` re-uploads the model).
    pub fn profile_stages(&mut self, cycles: u32) -> Result<DeviceProfile, GpuError> {
        on_engine!(&mut self.engine, e => e.profile_stages(cycles))
    }

    /// The adapter's `copy_buffer_to_buffer` bandwidth, bytes read + written per second.
    pub fn copy_bandwidth(&self) -> Result<f64, GpuError> {
        copy_bandwidth(self.device())
    }

    /// The bandwidth yardstick: a streaming copy kernel's bytes read + written per second.
    pub fn stream_bandwidth(&self) -> Result<StreamBandwidth, GpuError> {
        stream_bandwidth(self.device())
    }

    /// The bytes each kernel must move per cycle for these counts, in this backend's precision.
    pub fn bytes_per_cycle(&self, blocks: usize, corners: usize, contacts: usize, materials: usize) -> Vec<StageBytes> {
        match self.precision() {
            super::Precision::F32 => bytes_per_cycle::<f32>(blocks, corners, contacts, materials),
            super::Precision::F64 => bytes_per_cycle::<f64>(blocks, corners, contacts, materials),
        }
    }
}
