//! The bandwidth yardstick `blockdem bench` divides an engine's byte model by, two ways, bytes
//! read + bytes written per second: a streaming copy kernel (`shaders/stream_copy.wgsl`) over
//! buffers far larger than any cache at several sizes, the best of several runs
//! ([`stream_bandwidth`]); and a large `copy_buffer_to_buffer` ([`copy_bandwidth`]), which on
//! NVIDIA's Vulkan driver goes through a copy engine at a quarter of what a kernel reaches (846
//! GB/s on an H100 whose HBM3 gives 3.35 TB/s). Dimension-free: it reads no engine's state.

use std::time::Instant;

use super::{wgsl, GpuDevice, GpuError};

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
    let src = wgsl::stream_copy_source();
    // In error scopes like every kernel's (a driver that refuses it gives an error, not a panic).
    let scopes = dev.creation_scopes();
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("stream_copy"), source: wgpu::ShaderSource::Wgsl(src.into()) });
    let (layout, pipeline_layout) = wgsl::layouts(device, "stream_copy", &[wgsl::storage(0, true), wgsl::storage(1, false)]);
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("stream_copy"),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("stream_copy"),
        compilation_options: Default::default(),
        cache: None,
    });
    scopes.check(dev)?;
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
        let groups = words.div_ceil(wgsl::STREAM_WORKGROUP_SIZE).clamp(1, wgsl::MAX_GROUPS_PER_DIMENSION);
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
