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

use std::time::Instant;

use super::layout::{Block, Contact, ContactForce, Corner, Flags, Material, Params, Real};
use super::{kernels, shaders, Engine, GpuBackend, GpuDevice, GpuError};

/// Per-stage device time of one cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceProfile {
    /// "timestamps" (pass timestamps of whole cycles) or "isolated dispatches" (each stage alone,
    /// timed on the host).
    pub method: &'static str,
    /// (kernel, seconds per cycle), in cycle order.
    pub stages: Vec<(&'static str, f64)>,
    /// Cycles (or dispatches per stage) measured.
    pub cycles: u32,
}

/// Bytes one stage must read and write per cycle (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StageBytes {
    pub stage: &'static str,
    pub read: u64,
    pub written: u64,
}

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

/// Measures the bandwidth of `copy_buffer_to_buffer` on `dev`: bytes read + bytes written per
/// second. The copy is repeated in one submission until it takes at least 0.2 s.
pub fn copy_bandwidth(dev: &GpuDevice) -> Result<f64, GpuError> {
    let size = (256u64 << 20).min(dev.summary.max_buffer_size / 2).min(dev.summary.max_storage_buffer_binding_size) & !3;
    let make = |label: &str, usage: wgpu::BufferUsages| {
        dev.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
    };
    let src = make("bandwidth source", wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST);
    let dst = make("bandwidth destination", wgpu::BufferUsages::COPY_DST);
    let run = |reps: u32| -> Result<f64, GpuError> {
        let start = Instant::now();
        let mut enc = dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bandwidth") });
        for _ in 0..reps {
            enc.copy_buffer_to_buffer(&src, 0, &dst, 0, size);
        }
        dev.queue.submit([enc.finish()]);
        dev.wait()?;
        Ok(start.elapsed().as_secs_f64())
    };
    // First touch: the driver may allocate the memory lazily.
    dev.queue.write_buffer(&src, 0, &vec![1u8; size as usize]);
    run(1)?;
    let mut reps = 1u32;
    let mut best = 0.0f64;
    for _ in 0..12 {
        let t = run(reps)?;
        best = best.max(2.0 * size as f64 * reps as f64 / t.max(1e-9));
        if t >= 0.2 || reps >= 4096 {
            break;
        }
        reps = (reps * 2).max((reps as f64 * 0.25 / t.max(1e-6)).min(4096.0) as u32);
    }
    Ok(best)
}

/// The bandwidth yardstick: what [`stream_bandwidth`] measured.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct StreamBandwidth {
    /// (bytes of one buffer, best bytes read + written per second at that size), smallest first.
    pub sizes: Vec<(u64, f64)>,
    /// The best over the sizes: the yardstick.
    pub best: f64,
}

/// The bandwidth yardstick from its two measurements: the faster of the streaming kernel and
/// `copy_buffer_to_buffer`, and which one it is. On hardware GPUs the kernel wins by far (a copy
/// engine reaches a quarter of the memory's bandwidth on an H100); on Mesa's software adapters the
/// copy is a memcpy at the host's bandwidth while their generated code moves storage words a few
/// lanes at a time, so the kernel would measure the compiler, not the memory.
pub fn yardstick(stream: Option<f64>, copy: Option<f64>) -> Option<(f64, &'static str)> {
    let (stream, copy) = (stream.unwrap_or(0.0), copy.unwrap_or(0.0));
    (stream.max(copy) > 0.0).then_some(if stream >= copy { (stream, "streaming kernel") } else { (copy, "copy_buffer_to_buffer") })
}

/// Buffer sizes the yardstick streams: all far past the last-level caches of GPUs (50 MiB on an
/// H100) and of the CPUs a software adapter runs on, so each word comes from memory. The largest
/// are left out where the adapter cannot bind them, and on a software adapter (whose "device
/// memory" is the host's, already measured by the host copy) past 128 MiB, to keep a CI run short.
const STREAM_SIZES: [u64; 4] = [64 << 20, 128 << 20, 512 << 20, 1 << 30];

/// Runs of the yardstick at each size, each timing enough copies to take `STREAM_RUN_S`.
const STREAM_RUNS: usize = 3;
const STREAM_RUN_S: f64 = 0.05;

/// Measures the bandwidth a compute kernel reaches on `dev` (`stream_copy.wgsl`): bytes read +
/// bytes written per second of a copy between two buffers, at each of `STREAM_SIZES` the
/// adapter can bind, the best of `STREAM_RUNS` runs each. Host-timed: each run is one
/// submission of enough copies to take `STREAM_RUN_S`, so a launch's cost is spread thin.
pub fn stream_bandwidth(dev: &GpuDevice) -> Result<StreamBandwidth, GpuError> {
    let limit = dev.summary.max_storage_buffer_binding_size.min(dev.summary.max_buffer_size);
    let cap = if dev.summary.is_software() { 128 << 20 } else { u64::MAX };
    let sizes: Vec<u64> = STREAM_SIZES.iter().copied().filter(|&s| s <= limit && s <= cap).collect();
    let sizes = if sizes.is_empty() { vec![(limit.min(64 << 20)) & !15] } else { sizes };
    let device = &dev.device;
    let src = shaders::source("stream_copy", dev.precision).ok_or_else(|| GpuError::Shader("no kernel stream_copy".into()))?;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("stream_copy"), source: wgpu::ShaderSource::Wgsl(src.into()) });
    let (layout, pipeline_layout) = kernels::layouts(device, "stream_copy", &[kernels::storage(0, true), kernels::storage(1, false)]);
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("stream_copy"),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("stream_copy"),
        compilation_options: Default::default(),
        cache: None,
    });
    let mut out = StreamBandwidth::default();
    for size in sizes {
        let make = |label: &str, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        let a = make("stream source", wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST);
        let b = make("stream destination", wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("stream_copy"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: a.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: b.as_entire_binding() },
            ],
        });
        let words = (size / 16) as u32;
        let groups = words.div_ceil(shaders::STREAM_WORKGROUP_SIZE).clamp(1, shaders::MAX_GROUPS_PER_DIMENSION);
        let run = |reps: u32| -> Result<f64, GpuError> {
            let start = Instant::now();
            let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("stream_copy") });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("stream_copy"), timestamp_writes: None });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &group, &[]);
                for _ in 0..reps {
                    pass.dispatch_workgroups(groups, 1, 1);
                }
            }
            dev.queue.submit([enc.finish()]);
            dev.wait()?;
            Ok(start.elapsed().as_secs_f64())
        };
        // First touch (the driver may place the memory lazily), then a copy count that takes
        // STREAM_RUN_S. Each word holds its own index, so that the copy can be checked.
        let pattern: Vec<u32> = (0..(size / 4) as u32).collect();
        dev.queue.write_buffer(&a, 0, bytemuck::cast_slice(&pattern));
        let once = run(1)?;
        let reps = ((STREAM_RUN_S / once.max(1e-6)) as u32).clamp(1, 4096);
        let mut best = 0.0f64;
        for _ in 0..STREAM_RUNS {
            let t = run(reps)?;
            best = best.max(2.0 * size as f64 * reps as f64 / t.max(1e-9));
        }
        // A yardstick that skipped words would flatter the card: the first size is read back
        // whole and must equal its source.
        if out.sizes.is_empty() {
            let copied: Vec<u32> = dev.read_pod(&b, pattern.len())?;
            if let Some(i) = copied.iter().zip(&pattern).position(|(x, y)| x != y) {
                return Err(GpuError::Device(format!(
                    "stream_copy left word {} of {} wrong (read {}, wrote {})",
                    i / 4,
                    pattern.len() / 4,
                    copied[i],
                    pattern[i]
                )));
            }
        }
        out.sizes.push((size, best));
        out.best = out.best.max(best);
    }
    Ok(out)
}

/// `BLOCKDEM_STAGE_TIMING=isolated` asks for isolated dispatches even where timestamps exist (to
/// compare the two methods on one adapter).
fn isolated_asked() -> bool {
    std::env::var("BLOCKDEM_STAGE_TIMING").is_ok_and(|v| v.eq_ignore_ascii_case("isolated"))
}

impl<R: Real> Engine<R> {
    fn profile_stages(&mut self, cycles: u32) -> Result<DeviceProfile, GpuError> {
        // The profiled cycles move the device's state on: the next run must start from the model.
        self.resumable = false;
        let (Some(buffers), Some(_)) = (self.buffers.as_ref(), self.bind_groups.as_ref()) else {
            return Err(GpuError::Setup("profile_stages needs a run first (no state on the device)".into()));
        };
        let cycles = cycles.max(1);
        let dev = &self.dev;
        let stages = self.stages(false);
        dev.queue.write_buffer(&buffers.flags, 0, bytemuck::bytes_of(&Flags::cleared()));
        // The cycle's own gather (fixed blocks skipped), whatever pass ran last.
        self.write_pass_params(false);
        let timestamps = dev.device.features().contains(wgpu::Features::TIMESTAMP_QUERY) && !isolated_asked();
        let mut sums = vec![0.0f64; stages.len()];
        if timestamps {
            let period_s = dev.queue.get_timestamp_period() as f64 * 1e-9;
            let per_cycle = 2 * stages.len() as u32;
            let cycles_per_set = (wgpu::QUERY_SET_MAX_QUERIES / per_cycle).max(1);
            let mut done = 0;
            while done < cycles {
                let n = (cycles - done).min(cycles_per_set);
                let count = n * per_cycle;
                let set = dev.device.create_query_set(&wgpu::QuerySetDescriptor { label: Some("stage timestamps"), ty: wgpu::QueryType::Timestamp, count });
                let resolve = dev.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("stage timestamps"),
                    size: count as u64 * 8,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let mut enc = dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("profiled cycles") });
                for c in 0..n {
                    for (i, d) in stages.iter().enumerate() {
                        let q = (c * stages.len() as u32 + i as u32) * 2;
                        let writes =
                            wgpu::ComputePassTimestampWrites { query_set: &set, beginning_of_pass_write_index: Some(q), end_of_pass_write_index: Some(q + 1) };
                        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(d.label), timestamp_writes: Some(writes) });
                        pass.set_pipeline(d.pipeline);
                        pass.set_bind_group(0, d.bind_group, &[]);
                        pass.dispatch_workgroups(d.grid.0, d.grid.1, 1);
                    }
                    // A halt raised by end_cycle (stage 7 due) would idle the later cycles: clear it.
                    enc.clear_buffer(&buffers.flags, 0, None);
                }
                enc.resolve_query_set(&set, 0..count, &resolve, 0);
                dev.queue.submit([enc.finish()]);
                let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&dev.read_buffer(&resolve, count as u64 * 8)?);
                for (q, pair) in ticks.chunks_exact(2).enumerate() {
                    sums[q % stages.len()] += pair[1].saturating_sub(pair[0]) as f64 * period_s;
                }
                done += n;
            }
        } else {
            for (i, d) in stages.iter().enumerate() {
                let batch = |reps: u32| -> Result<f64, GpuError> {
                    let start = Instant::now();
                    let mut enc = dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("isolated stage") });
                    for _ in 0..reps {
                        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(d.label), timestamp_writes: None });
                        pass.set_pipeline(d.pipeline);
                        pass.set_bind_group(0, d.bind_group, &[]);
                        pass.dispatch_workgroups(d.grid.0, d.grid.1, 1);
                    }
                    dev.queue.submit([enc.finish()]);
                    dev.wait()?;
                    Ok(start.elapsed().as_secs_f64())
                };
                batch(1)?;
                dev.queue.write_buffer(&buffers.flags, 0, bytemuck::bytes_of(&Flags::cleared()));
                sums[i] = batch(cycles)?;
            }
        }
        Ok(DeviceProfile {
            method: if timestamps { "timestamps" } else { "isolated dispatches" },
            stages: stages.iter().zip(&sums).map(|(d, s)| (d.label, s / cycles as f64)).collect(),
            cycles,
        })
    }
}

impl GpuBackend {
    fn device(&self) -> &GpuDevice {
        on_engine!(&self.engine, e => &e.dev)
    }

    /// Whether the device writes pass timestamps (stage times are then measured inside cycles).
    pub fn has_timestamps(&self) -> bool {
        self.device().device.features().contains(wgpu::Features::TIMESTAMP_QUERY) && !isolated_asked()
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
