//! The GPU configurations a suite runs on (STYLE.md item 8): every adapter with compute shaders
//! that wgpu finds, in f32 and, where it has `SHADER_F64`, in f64. One list for the scenario
//! tests (tests/suite/common) and for `blockdem verify`, so both cover the same backends. On a machine
//! with Mesa's software adapters only, that is Vulkan (lavapipe) f32 and f64 and GL (llvmpipe)
//! f32.

use super::device::{list_adapters, matching_adapters, AdapterChoice, AdapterSummary, GpuApi};
use super::{GpuBackend, GpuError, GpuOptions, Precision};

/// One adapter in one precision.
#[derive(Clone, Debug)]
pub struct GpuTarget {
    /// Options that open exactly this adapter.
    pub options: GpuOptions,
    pub adapter: AdapterSummary,
}

impl GpuTarget {
    /// "vulkan (lavapipe)", "gl (llvmpipe)", "vulkan (NVIDIA GeForce RTX 4090)": the API and the
    /// adapter's name without its parenthesised details. Mesa's software Vulkan driver, lavapipe,
    /// names its device "llvmpipe" like the GL one; the label uses the driver's own name.
    pub fn label(&self) -> String {
        let a = &self.adapter;
        let api = a.backend.to_lowercase();
        let mut name = a.name.split(" (").next().unwrap_or(&a.name).trim().to_string();
        if api == "vulkan" && name == "llvmpipe" {
            name = "lavapipe".into();
        }
        format!("{api} ({name})")
    }

    pub fn precision(&self) -> Precision {
        self.options.precision
    }

    /// A fresh backend on this adapter.
    pub fn backend(&self) -> Result<GpuBackend, GpuError> {
        GpuBackend::new(&self.options)
    }
}

fn api_of(a: &AdapterSummary) -> Option<GpuApi> {
    match a.backend.as_str() {
        "Vulkan" => Some(GpuApi::Vulkan),
        "Gl" => Some(GpuApi::Gl),
        _ => None,
    }
}

/// Whether a device opens with these options (remembered per process: a check costs a device).
/// An adapter can be listed and still refuse every device: NVIDIA's GL through EGL without a
/// display does (wgpu reports "Parent device is lost"); such an adapter is no target. On GL the
/// cycle's kernels are built too: wgpu translates WGSL to GLSL when a pipeline is made, and a
/// driver whose context is older than compute shaders (NVIDIA's EGL gives GL 3.3 without a
/// display) lists compute and still rejects every kernel, so it is no target either (as the bench
/// refuses it when it opens it). Vulkan's SPIR-V has no such version gate; its kernels are left
/// to the backend.
pub fn device_opens(options: &GpuOptions) -> Result<(), String> {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    static OPENED: OnceLock<Mutex<HashMap<String, Result<(), String>>>> = OnceLock::new();
    let key = format!("{:?} {:?}", options.adapter, options.precision);
    let cache = OPENED.get_or_init(Default::default);
    if let Some(known) = cache.lock().ok().and_then(|c| c.get(&key).cloned()) {
        return known;
    }
    let on_gl = matches!(options.adapter, AdapterChoice::Gl | AdapterChoice::OnApi(GpuApi::Gl, _));
    let result = super::GpuDevice::open(&options.adapter, options.precision)
        .and_then(|dev| if on_gl { super::kernels::Pipelines::new(&dev).map(|_| ()) } else { Ok(()) })
        .map_err(|e| e.to_string());
    if let Ok(mut c) = cache.lock() {
        c.insert(key, result.clone());
    }
    result
}

/// The adapter `choice` opens in `precision`, when it is there: an adapter with compute shaders,
/// `SHADER_F64` for f64, on which a device opens.
pub fn find_target(choice: &AdapterChoice, precision: Precision) -> Option<GpuTarget> {
    let mut found: Vec<AdapterSummary> = matching_adapters(choice).into_iter().filter(|a| a.compute && (precision == Precision::F32 || a.shader_f64)).collect();
    found.sort_by_key(rank);
    let adapter = found.into_iter().next()?;
    opening(GpuTarget { options: GpuOptions { adapter: choice.clone(), precision }, adapter })
}

/// The target if a device opens on it; else None, after saying why.
fn opening(target: GpuTarget) -> Option<GpuTarget> {
    match device_opens(&target.options) {
        Ok(()) => Some(target),
        Err(e) => {
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), "blockdem: {} {} is listed but opens no device: {e}", target.label(), target.precision());
            None
        }
    }
}

/// Hardware before software, Vulkan before GL (the order `GpuDevice::open` ranks adapters in).
fn rank(a: &AdapterSummary) -> (u8, u8) {
    let kind = match a.device_type.as_str() {
        "DiscreteGpu" => 0,
        "IntegratedGpu" => 1,
        "VirtualGpu" => 2,
        "Cpu" => 4,
        _ => 3,
    };
    (kind, u8::from(a.backend != "Vulkan"))
}

/// Every GPU target present, in the order hardware before software, Vulkan before GL, f32 before
/// f64: each adapter with compute shaders on Vulkan or GL, in f32, and in f64 where it has
/// `SHADER_F64`. Each target's options name its API and adapter, so it opens that one adapter.
pub fn scenario_backends() -> Vec<GpuTarget> {
    let mut adapters: Vec<AdapterSummary> = list_adapters(&AdapterChoice::Any).into_iter().filter(|a| a.compute && api_of(a).is_some()).collect();
    adapters.sort_by_key(rank);
    let mut out = Vec::new();
    let mut seen: Vec<(String, String)> = Vec::new();
    for a in adapters {
        // One entry per API and name: the options pick an adapter by those two (a driver may
        // list one device twice, and two equal cards are one configuration).
        if seen.contains(&(a.backend.clone(), a.name.clone())) {
            continue;
        }
        seen.push((a.backend.clone(), a.name.clone()));
        let api = api_of(&a).expect("filtered above");
        let precisions: &[Precision] = if a.shader_f64 { &[Precision::F32, Precision::F64] } else { &[Precision::F32] };
        for &precision in precisions {
            out.extend(opening(GpuTarget { options: GpuOptions { adapter: AdapterChoice::OnApi(api, a.name.clone()), precision }, adapter: a.clone() }));
        }
    }
    out
}
