//! What `blockdem bench` measures of any engine's GPU cycle beyond running it, dimension-free:
//! each kernel's time per cycle ([`time_passes`]) and the bytes each must move (the byte model's
//! row, [`StageBytes`]). Each engine says which passes its cycle is and what they move
//! (`udec::gpu::profile`, `d3::gpu::profile`).
//!
//! Times: with `TIMESTAMP_QUERY` (requested at device set-up where the adapter has it) each pass
//! of a normal cycle writes a timestamp at its start and end; without it, each pass is dispatched
//! alone, many times in one submission, and timed on the host (`BLOCKDEM_STAGE_TIMING=isolated`
//! asks for this even where timestamps exist). Either way the passes run on the state the
//! engine's last run left on the device and change it: the engine's next run must upload its
//! model again.

use std::time::Instant;

use super::{GpuDevice, GpuError};

/// Per-kernel device time of one cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceProfile {
    /// "timestamps" (pass timestamps of whole cycles) or "isolated dispatches" (each pass alone,
    /// timed on the host).
    pub method: &'static str,
    /// (kernel, seconds per cycle), in cycle order.
    pub stages: Vec<(&'static str, f64)>,
    /// Cycles (or dispatches per pass) measured.
    pub cycles: u32,
}

/// Bytes one kernel must read and write per cycle (the byte model: its compulsory traffic, every
/// struct it reads counted once a cycle, as if fetched from memory once and then cached, and
/// the fields it stores once).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StageBytes {
    pub stage: &'static str,
    pub read: u64,
    pub written: u64,
}

/// One pass of a cycle as it is timed: its kernel's label, pipeline, bind group and grid.
pub struct Pass<'a> {
    pub label: &'static str,
    pub pipeline: &'a wgpu::ComputePipeline,
    pub bind_group: &'a wgpu::BindGroup,
    pub grid: (u32, u32),
}

/// `BLOCKDEM_STAGE_TIMING=isolated` asks for isolated dispatches even where timestamps exist (to
/// compare the two methods on one adapter).
pub fn isolated_asked() -> bool {
    std::env::var("BLOCKDEM_STAGE_TIMING").is_ok_and(|v| v.eq_ignore_ascii_case("isolated"))
}

/// Whether `dev` times passes by timestamps (else by isolated dispatches).
pub fn has_timestamps(dev: &GpuDevice) -> bool {
    dev.device.features().contains(wgpu::Features::TIMESTAMP_QUERY) && !isolated_asked()
}

/// Each pass's device time per cycle over `cycles` cycles of `passes` (see the module doc).
/// `between_cycles` is encoded after each timed cycle (clearing what would idle the next, a halt
/// flag); `before_timed` runs before each isolated pass's timed dispatches (after one untimed).
pub fn time_passes(
    dev: &GpuDevice,
    passes: &[Pass],
    cycles: u32,
    between_cycles: &dyn Fn(&mut wgpu::CommandEncoder),
    before_timed: &dyn Fn(),
) -> Result<DeviceProfile, GpuError> {
    let cycles = cycles.max(1);
    let timestamps = has_timestamps(dev);
    let mut sums = vec![0.0f64; passes.len()];
    if timestamps {
        let period_s = dev.queue.get_timestamp_period() as f64 * 1e-9;
        let per_cycle = 2 * passes.len() as u32;
        let cycles_per_set = (wgpu::QUERY_SET_MAX_QUERIES / per_cycle.max(1)).max(1);
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
                for (i, d) in passes.iter().enumerate() {
                    let q = (c * passes.len() as u32 + i as u32) * 2;
                    let writes =
                        wgpu::ComputePassTimestampWrites { query_set: &set, beginning_of_pass_write_index: Some(q), end_of_pass_write_index: Some(q + 1) };
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(d.label), timestamp_writes: Some(writes) });
                    pass.set_pipeline(d.pipeline);
                    pass.set_bind_group(0, d.bind_group, &[]);
                    pass.dispatch_workgroups(d.grid.0, d.grid.1, 1);
                }
                between_cycles(&mut enc);
            }
            enc.resolve_query_set(&set, 0..count, &resolve, 0);
            dev.queue.submit([enc.finish()]);
            let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&dev.read_buffer(&resolve, count as u64 * 8)?);
            for (q, pair) in ticks.chunks_exact(2).enumerate() {
                sums[q % passes.len()] += pair[1].saturating_sub(pair[0]) as f64 * period_s;
            }
            done += n;
        }
    } else {
        for (i, d) in passes.iter().enumerate() {
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
            before_timed();
            sums[i] = batch(cycles)?;
        }
    }
    Ok(DeviceProfile {
        method: if timestamps { "timestamps" } else { "isolated dispatches" },
        stages: passes.iter().zip(&sums).map(|(d, s)| (d.label, s / cycles as f64)).collect(),
        cycles,
    })
}
