//! Device set-up, separate from the work (DESIGN.md §3): finds adapters (honouring wgpu's
//! `WGPU_BACKEND` and `WGPU_ADAPTER_NAME`), requests a device with the adapter's own limits, and
//! bounds every wait. Off-screen only: no window, no surface. Errors are values, never panics.

use std::time::Duration;

use super::{GpuError, Precision};

/// Which adapter to use (`--adapter`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AdapterChoice {
    /// Vulkan only (NVIDIA, AMD, Intel, Mesa lavapipe on CPUs).
    Vulkan,
    /// OpenGL ES / GL through EGL only (Mesa llvmpipe on CPUs).
    Gl,
    /// The best adapter of any backend: a discrete or integrated GPU before a CPU emulation,
    /// Vulkan before GL.
    Any,
    /// The first adapter whose name contains this text (case-insensitive).
    Name(String),
    /// The first adapter of one graphics API whose name contains this text: one adapter exactly
    /// (Mesa's software Vulkan and GL adapters share the name "llvmpipe"), as the suites pick
    /// each adapter they find (`gpu::scenario_backends`).
    OnApi(GpuApi, String),
}

/// The graphics APIs the GPU backend runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuApi {
    Vulkan,
    Gl,
}

impl std::str::FromStr for AdapterChoice {
    type Err = std::convert::Infallible;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "vulkan" | "vk" => AdapterChoice::Vulkan,
            "gl" | "gles" | "opengl" => AdapterChoice::Gl,
            "any" | "" => AdapterChoice::Any,
            _ => AdapterChoice::Name(s.to_string()),
        })
    }
}

impl AdapterChoice {
    /// The text an adapter's name must contain (lower case): the name asked for, or, for `Any`,
    /// `WGPU_ADAPTER_NAME` when set.
    pub fn wanted_name(&self) -> Option<String> {
        match self {
            AdapterChoice::Name(n) | AdapterChoice::OnApi(_, n) => Some(n.to_lowercase()),
            AdapterChoice::Any => std::env::var("WGPU_ADAPTER_NAME").ok().map(|n| n.to_lowercase()),
            _ => None,
        }
    }

    /// The choice as `--adapter` spells it, for messages.
    pub fn as_arg(&self) -> String {
        match self {
            AdapterChoice::Vulkan => "vulkan".into(),
            AdapterChoice::Gl => "gl".into(),
            AdapterChoice::Any => "any".into(),
            AdapterChoice::Name(n) => n.clone(),
            AdapterChoice::OnApi(api, n) => format!("{n} on {api:?}"),
        }
    }
}

/// Longest a single wait on the device may take before the run stops with an error: lavapipe
/// has no watchdog, so a runaway kernel would otherwise hang the process.
pub const WAIT_TIMEOUT: Duration = Duration::from_secs(120);

/// The backends to look at: `WGPU_BACKEND` when set, else Vulkan and GL.
fn backends_for(choice: &AdapterChoice) -> wgpu::Backends {
    let base = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::VULKAN | wgpu::Backends::GL);
    match choice {
        AdapterChoice::Vulkan => base & wgpu::Backends::VULKAN,
        AdapterChoice::Gl | AdapterChoice::OnApi(GpuApi::Gl, _) => base & wgpu::Backends::GL,
        AdapterChoice::OnApi(GpuApi::Vulkan, _) => base & wgpu::Backends::VULKAN,
        _ => base,
    }
}

fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    // Headless (no X11 or Wayland display): say so to Mesa before it probes for a display.
    // - GL: wgpu already asks EGL for Mesa's surfaceless platform when it has no display handle;
    //   EGL_PLATFORM=surfaceless makes Mesa's own default agree.
    // - Vulkan: Mesa's implicit device-select layer calls wl_display_connect to find the
    //   "primary" GPU, which prints "XDG_RUNTIME_DIR is invalid or not set" on every instance;
    //   NODEVICE_SELECT=1 turns that layer off (it only reorders devices; we rank them ourselves).
    // Both only when the user has not set them, and once per process.
    static HEADLESS_ENV: std::sync::Once = std::sync::Once::new();
    HEADLESS_ENV.call_once(|| {
        let headless = std::env::var_os("WAYLAND_DISPLAY").is_none() && std::env::var_os("DISPLAY").is_none();
        if headless {
            for (key, value) in [("EGL_PLATFORM", "surfaceless"), ("NODEVICE_SELECT", "1")] {
                if std::env::var_os(key).is_none() {
                    // SAFETY: done once, before the first wgpu instance of the process (the
                    // binary sets up the device before any other thread exists; scripts/test.sh
                    // exports both so that test threads never race here).
                    unsafe { std::env::set_var(key, value) };
                }
            }
        }
    });
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    desc.backends = backends;
    // The grids of the cycle's indirect dispatches are written by the CPU (`dispatch_grid`, within
    // the 65535 limit) or zeroed by end_cycle, and no kernel reads `num_workgroups`; wgpu's check
    // of them (a small compute pass before every indirect dispatch) cost 30% of a 10³-block cycle
    // on lavapipe. WGPU_VALIDATION_INDIRECT_CALL=1 turns it back on.
    if std::env::var_os("WGPU_VALIDATION_INDIRECT_CALL").is_none() {
        desc.flags.remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    }
    wgpu::Instance::new(desc)
}

/// What `blockdem adapters` prints about one adapter.
#[derive(Clone, Debug)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    pub max_storage_buffers_per_shader_stage: u32,
    pub max_storage_buffer_binding_size: u64,
    pub max_buffer_size: u64,
    pub max_compute_workgroup_size_x: u32,
    pub shader_f64: bool,
    /// Whether compute shaders are there at all (GL ES 3.0 adapters lack them).
    pub compute: bool,
}

impl AdapterSummary {
    /// The driver's name, or "driver unnamed" where the driver gives none (Mesa's GL adapter,
    /// which showed as `[]`).
    pub fn driver_name(&self) -> &str {
        if self.driver.trim().is_empty() {
            "driver unnamed"
        } else {
            &self.driver
        }
    }

    /// A software adapter (Mesa's lavapipe and llvmpipe): it runs on the host's cores, and its
    /// device memory is the host's.
    pub fn is_software(&self) -> bool {
        self.device_type == "Cpu"
    }

    fn of(adapter: &wgpu::Adapter) -> Self {
        let info = adapter.get_info();
        let limits = adapter.limits();
        AdapterSummary {
            name: info.name,
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver,
            driver_info: info.driver_info,
            max_storage_buffers_per_shader_stage: limits.max_storage_buffers_per_shader_stage,
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_buffer_size: limits.max_buffer_size,
            max_compute_workgroup_size_x: limits.max_compute_workgroup_size_x,
            shader_f64: adapter.features().contains(wgpu::Features::SHADER_F64),
            compute: adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS),
        }
    }
}

/// Every adapter wgpu finds on the backends `choice` allows.
pub fn list_adapters(choice: &AdapterChoice) -> Vec<AdapterSummary> {
    let backends = backends_for(choice);
    if backends.is_empty() {
        return Vec::new();
    }
    let inst = instance(backends);
    pollster::block_on(inst.enumerate_adapters(backends)).iter().map(AdapterSummary::of).collect()
}

/// The adapters `choice` may open: on the backends it allows, with the name it asks for.
pub fn matching_adapters(choice: &AdapterChoice) -> Vec<AdapterSummary> {
    let mut found = list_adapters(choice);
    if let Some(n) = choice.wanted_name() {
        found.retain(|a| a.name.to_lowercase().contains(&n));
    }
    found
}

fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    let backend = if info.backend == wgpu::Backend::Vulkan { 0 } else { 1 };
    (kind, backend)
}

/// The error scopes of [`GpuDevice::creation_scopes`], the innermost first (so that, dropped
/// unchecked on an early return, they close in order).
#[must_use = "the scopes are checked with `check`"]
pub struct CreationScopes {
    validation: wgpu::ErrorScopeGuard,
    internal: wgpu::ErrorScopeGuard,
}

impl CreationScopes {
    /// Closes the scopes: what the driver rejected within them, as `GpuError::Shader` naming the
    /// adapter.
    pub fn check(self, dev: &GpuDevice) -> Result<(), GpuError> {
        let CreationScopes { validation, internal } = self;
        let rejected = [pollster::block_on(validation.pop()), pollster::block_on(internal.pop())];
        match rejected.into_iter().flatten().next() {
            Some(e) => Err(GpuError::Shader(format!(
                "the driver of {} ({} {}) rejected a kernel: {e}",
                dev.summary.name, dev.summary.backend, dev.summary.driver_info
            ))),
            None => Ok(()),
        }
    }
}

/// A device ready for the kernels.
pub struct GpuDevice {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub summary: AdapterSummary,
    pub precision: Precision,
    /// The first error wgpu raised outside an error scope (its default handler would panic).
    uncaptured: std::sync::Arc<std::sync::Mutex<Option<String>>>,
    /// The read-back staging buffer, kept between read-backs (`read_parts`).
    staging: std::sync::Mutex<Option<wgpu::Buffer>>,
    /// Bytes read back so far (`read_gathered`), for the benchmark's transfer figures.
    read_bytes: std::sync::atomic::AtomicU64,
}

impl GpuDevice {
    /// Finds the adapter `choice` names (or `WGPU_ADAPTER_NAME` when set and `choice` is `Any`)
    /// and opens a device on it with the adapter's own limits.
    pub fn open(choice: &AdapterChoice, precision: Precision) -> Result<Self, GpuError> {
        let backends = backends_for(choice);
        if backends.is_empty() {
            return Err(GpuError::NoAdapter(format!(
                "no wgpu backend allowed for --adapter {choice:?} (WGPU_BACKEND={:?})",
                std::env::var("WGPU_BACKEND").unwrap_or_default()
            )));
        }
        let inst = instance(backends);
        let mut adapters: Vec<wgpu::Adapter> = pollster::block_on(inst.enumerate_adapters(backends))
            .into_iter()
            .filter(|a| a.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS | wgpu::DownlevelFlags::INDIRECT_EXECUTION))
            .collect();
        let wanted_name = choice.wanted_name();
        if let Some(name) = &wanted_name {
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(name.as_str()));
        }
        if precision == Precision::F64 {
            // Named as found, with the API: `--adapter any` under WGPU_BACKEND=gl is GL's adapter.
            let found: Vec<String> = adapters.iter().map(|a| a.get_info()).map(|i| format!("{} ({:?})", i.name, i.backend)).collect();
            adapters.retain(|a| a.features().contains(wgpu::Features::SHADER_F64));
            if adapters.is_empty() && !found.is_empty() {
                let env = std::env::var("WGPU_BACKEND").map(|v| format!(" with WGPU_BACKEND={v}")).unwrap_or_default();
                return Err(GpuError::NoF64(format!("--adapter {}{env} finds only {}", choice.as_arg(), found.join(", "))));
            }
        }
        adapters.sort_by_key(|a| rank(&a.get_info()));
        let adapter = adapters.into_iter().next().ok_or_else(|| {
            GpuError::NoAdapter(match &wanted_name {
                Some(n) => format!("no adapter with compute shaders and indirect dispatch whose name contains {n:?}"),
                None => format!("no adapter with compute shaders and indirect dispatch on {backends:?}"),
            })
        })?;
        let summary = AdapterSummary::of(&adapter);
        let mut features = wgpu::Features::empty();
        if precision == Precision::F64 {
            features |= wgpu::Features::SHADER_F64;
        }
        // Timestamp queries where the adapter has them: `blockdem bench` times each stage's pass.
        features |= adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        // The adapter's own limits: the 256 MiB default buffer cap is too small for big scenes.
        let limits = adapter.limits();
        if limits.max_storage_buffers_per_shader_stage < 7 {
            return Err(GpuError::Setup(format!(
                "adapter {} offers {} storage buffers per stage; the kernels need 7",
                summary.name, limits.max_storage_buffers_per_shader_stage
            )));
        }
        // Some drivers refuse a device with everything the adapter advertises (NVIDIA's GL through
        // EGL has answered "device lost"): then without timestamps, then with the limits the
        // kernels need rather than the adapter's all.
        let mut needed = wgpu::Limits::downlevel_defaults();
        needed.max_storage_buffers_per_shader_stage = 8;
        needed.max_storage_buffer_binding_size = limits.max_storage_buffer_binding_size;
        needed.max_buffer_size = limits.max_buffer_size;
        needed.max_compute_workgroup_size_x = needed.max_compute_workgroup_size_x.max(256).min(limits.max_compute_workgroup_size_x);
        needed.max_compute_invocations_per_workgroup = needed.max_compute_invocations_per_workgroup.max(256).min(limits.max_compute_invocations_per_workgroup);
        let attempts =
            [(features, limits.clone()), (features - wgpu::Features::TIMESTAMP_QUERY, limits.clone()), (features - wgpu::Features::TIMESTAMP_QUERY, needed)];
        let mut refusals = Vec::new();
        let mut opened = None;
        for (f, l) in attempts {
            match pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("blockdem"),
                required_features: f,
                required_limits: l,
                ..Default::default()
            })) {
                Ok(dq) => {
                    opened = Some(dq);
                    break;
                }
                Err(e) => refusals.push(e.to_string()),
            }
        }
        let (device, queue) = opened.ok_or_else(|| GpuError::Setup(format!("cannot open a device on {}: {}", summary.name, refusals.join("; then "))))?;
        // wgpu's default handler panics on an error outside an error scope; keep it instead and
        // turn it into an error value at the next wait.
        let uncaptured = std::sync::Arc::new(std::sync::Mutex::new(None::<String>));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(std::sync::Arc::new(move |e: wgpu::Error| {
            if let Ok(mut slot) = sink.lock() {
                slot.get_or_insert_with(|| e.to_string());
            }
        }));
        Ok(GpuDevice { device, queue, summary, precision, uncaptured, staging: std::sync::Mutex::new(None), read_bytes: Default::default() })
    }

    /// Opens validation and internal error scopes for the creation of shader modules and
    /// pipelines: [`CreationScopes::check`] then turns a driver's rejection into an error value
    /// at set-up, not a panic or a failure at the first dispatch. (NVIDIA's GL through EGL gives
    /// wgpu 30 a GL 3.3 context that advertises compute shaders, and its shader translation then
    /// refuses every kernel with an *internal* error: seen on an H100, 2026-11-26.)
    pub fn creation_scopes(&self) -> CreationScopes {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        CreationScopes { validation, internal }
    }

    /// Waits for all submitted work, at most `WAIT_TIMEOUT`.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::Wait { submission_index: None, timeout: Some(WAIT_TIMEOUT) }).map_err(|e| {
            GpuError::Device(format!("waiting for the GPU: {e} (a kernel ran longer than {} s or the device was lost)", WAIT_TIMEOUT.as_secs()))
        })?;
        if let Some(e) = self.uncaptured.lock().ok().and_then(|mut slot| slot.take()) {
            return Err(GpuError::Device(e));
        }
        Ok(())
    }

    /// Copies `size` bytes of `buffer` back to the CPU (bounded wait).
    pub fn read_buffer(&self, buffer: &wgpu::Buffer, size: u64) -> Result<Vec<u8>, GpuError> {
        self.read_pod(buffer, size as usize)
    }

    /// Copies the first `size` bytes of each of `parts` into one staging buffer with one
    /// submission and one (bounded) wait, and hands `f` the bytes of each part, still mapped
    /// (each part starts 16-byte aligned, so `bytemuck::cast_slice` to the GPU structs works).
    pub fn read_parts<T>(&self, parts: &[(&wgpu::Buffer, u64)], f: impl FnOnce(&[&[u8]]) -> T) -> Result<T, GpuError> {
        let ranges: Vec<[(&wgpu::Buffer, u64, u64); 1]> = parts.iter().map(|&(buffer, size)| [(buffer, 0, size)]).collect();
        let gathered: Vec<&[(&wgpu::Buffer, u64, u64)]> = ranges.iter().map(|r| &r[..]).collect();
        self.read_gathered(&gathered, f)
    }

    /// As `read_parts`, each part gathered from ranges (buffer, byte offset, bytes) laid end to
    /// end: a contact update reads the few blocks, corners and contacts it touches this way, one
    /// copy per run of neighbouring items. Offsets and sizes are multiples of 4 (whole structs).
    pub fn read_gathered<T>(&self, parts: &[&[(&wgpu::Buffer, u64, u64)]], f: impl FnOnce(&[&[u8]]) -> T) -> Result<T, GpuError> {
        let mut offsets = Vec::with_capacity(parts.len());
        let mut sizes = Vec::with_capacity(parts.len());
        let mut total = 0u64;
        for ranges in parts {
            let size: u64 = ranges.iter().map(|r| r.2).sum();
            offsets.push(total);
            sizes.push(size);
            total += size.next_multiple_of(16);
        }
        if total == 0 {
            let empty: Vec<&[u8]> = parts.iter().map(|_| &[][..]).collect();
            return Ok(f(&empty));
        }
        // One staging buffer, kept and grown as needed: a contact update of a large model may
        // read the whole state back, and allocating that much mappable memory each time costs.
        let kept = self.staging.lock().ok().and_then(|mut s| s.take()).filter(|b| b.size() >= total);
        let staging = kept.unwrap_or_else(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: total + total / 4,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        let mut enc = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        for (ranges, &offset) in parts.iter().zip(&offsets) {
            let mut at = offset;
            for &(buffer, from, size) in ranges.iter() {
                if size > 0 {
                    enc.copy_buffer_to_buffer(buffer, from, &staging, at, size);
                }
                at += size;
            }
        }
        self.queue.submit([enc.finish()]);
        self.read_bytes.fetch_add(sizes.iter().sum::<u64>(), std::sync::atomic::Ordering::Relaxed);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, ..total, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        match rx.try_recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Device(format!("mapping a read-back buffer: {e}"))),
            Err(_) => return Err(GpuError::Device("a read-back did not complete".into())),
        }
        let result = {
            let view = staging.get_mapped_range(..total).map_err(|e| GpuError::Device(format!("reading a mapped buffer: {e:?}")))?;
            let slices: Vec<&[u8]> = sizes.iter().zip(&offsets).map(|(&size, &o)| &view[o as usize..(o + size) as usize]).collect();
            f(&slices)
        };
        staging.unmap();
        if let Ok(mut kept) = self.staging.lock() {
            *kept = Some(staging);
        }
        Ok(result)
    }

    /// Bytes read back from the device so far.
    pub fn bytes_read(&self) -> u64 {
        self.read_bytes.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Copies the first `n` items of type `T` of `buffer` back to the CPU (bounded wait), with
    /// one copy out of the mapped staging memory.
    pub fn read_pod<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, n: usize) -> Result<Vec<T>, GpuError> {
        self.read_parts(&[(buffer, (n * std::mem::size_of::<T>()) as u64)], |bytes| bytemuck::pod_collect_to_vec(bytes[0]))
    }
}

/// The largest storage binding this device may hold: the adapter's own limit (128 MiB on Mesa's
/// software adapters, 2 GiB on NVIDIA's Vulkan driver), within its largest buffer.
pub fn binding_cap(dev: &GpuDevice) -> u64 {
    dev.summary.max_storage_buffer_binding_size.min(dev.summary.max_buffer_size)
}

/// Why a buffer cannot be made, with advice that fits the run: f32 halves most buffers; in f32
/// only a smaller model (at most cap / item of these items), an adapter with larger bindings or
/// the CPU backend helps.
pub(crate) fn too_large(label: &str, need: u64, cap: u64, item: usize, precision: Precision) -> String {
    let advice = match precision {
        Precision::F64 => "use a smaller model or --precision f32 (about half the bytes)".to_string(),
        Precision::F32 => format!(
            "use a smaller model (at most {} {label} here), an adapter with larger bindings (hardware GPUs allow 2 GiB and more) or --backend cpu (no such limit)",
            cap / item as u64
        ),
    };
    format!("the {label} buffer would need {need} bytes, more than one binding may hold on this adapter ({cap} bytes); {advice}")
}

/// Whether `count` items of `item` bytes fit one binding of `cap` bytes; if not, the error that
/// making their buffer would give.
pub fn check_fits(label: &str, item: usize, count: usize, cap: u64, precision: Precision) -> Result<(), GpuError> {
    let need = (count.max(1) * item) as u64;
    if need > cap {
        return Err(GpuError::DoesNotFit(too_large(label, need, cap, item, precision)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model too large for one binding is refused with advice that fits the run: f32 only where
    /// the run is in f64, and in f32 how many items the adapter's binding holds.
    #[test]
    fn a_buffer_past_the_binding_limit_gets_advice_for_its_precision() {
        let cap = 134_217_728;
        let f32_msg = too_large("corners", 160_000_560, cap, 40, Precision::F32);
        assert!(f32_msg.contains("160000560 bytes") && f32_msg.contains("(134217728 bytes)"), "{f32_msg}");
        assert!(f32_msg.contains("at most 3355443 corners here") && !f32_msg.contains("--precision f32"), "{f32_msg}");
        let f64_msg = too_large("contacts", 960_000_000, cap, 120, Precision::F64);
        assert!(f64_msg.contains("--precision f32"), "{f64_msg}");
        // The check a run makes before its full detection gives the same refusal, and passes
        // what fits.
        match check_fits("corners", 40, 4_000_014, cap, Precision::F32) {
            Err(GpuError::DoesNotFit(m)) => assert!(m.contains("160000560 bytes") && m.contains("at most 3355443 corners here"), "{m}"),
            other => panic!("{other:?}"),
        }
        assert!(check_fits("corners", 40, 3_355_443, cap, Precision::F32).is_ok());
    }
}
