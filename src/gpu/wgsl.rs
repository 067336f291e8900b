//! WGSL that every engine's kernels share, and naga validation (STYLE.md item 4: constants
//! live in Rust and reach the shaders through a prelude an engine writes with these).

use super::Precision;

/// Threads per workgroup of the per-item kernels, unless `BLOCKDEM_WORKGROUP_SIZE` says otherwise
/// ([`workgroup_size`]).
pub const WORKGROUP_SIZE: u32 = 64;

/// Threads per workgroup of the per-item kernels: [`WORKGROUP_SIZE`], or `BLOCKDEM_WORKGROUP_SIZE`
/// (32, 64, 128 or 256; anything else is ignored) to measure another size on a GPU
/// (docs/BENCHMARKS.md). Results do not depend on it, except the energy sums' reduction order
/// (`energy_sums.wgsl`), which moves the ledger by round-off. Read once per process.
pub fn workgroup_size() -> u32 {
    static SIZE: std::sync::OnceLock<u32> = std::sync::OnceLock::new();
    *SIZE.get_or_init(|| {
        std::env::var("BLOCKDEM_WORKGROUP_SIZE").ok().and_then(|v| v.trim().parse().ok()).filter(|n| [32, 64, 128, 256].contains(n)).unwrap_or(WORKGROUP_SIZE)
    })
}

/// Threads per workgroup of the bandwidth yardstick (`stream_copy`): 256, the size streaming
/// kernels commonly run best at on NVIDIA and AMD hardware (enough warps a multiprocessor to hide
/// memory latency).
pub const STREAM_WORKGROUP_SIZE: u32 = 256;

/// Most workgroups a dispatch may have in one dimension (WebGPU's default limit).
pub const MAX_GROUPS_PER_DIMENSION: u32 = 65535;

/// The two-dimensional dispatch that covers `groups` workgroups (rows of at most
/// `MAX_GROUPS_PER_DIMENSION`; `item_index` in layout.wgsl lays them end to end).
pub fn dispatch_grid(groups: u32) -> (u32, u32) {
    // A grid of more than one row has rows of MAX_GROUPS_PER_DIMENSION workgroups, the
    // GROUPS_PER_ROW of the prelude that `workgroup_index` counts with.
    if groups <= MAX_GROUPS_PER_DIMENSION {
        (groups, 1)
    } else {
        (MAX_GROUPS_PER_DIMENSION, groups.div_ceil(MAX_GROUPS_PER_DIMENSION))
    }
}

/// The bandwidth yardstick's kernel (`shaders/stream_copy.wgsl`, Rust twin
/// [`stream_bandwidth`](super::stream::stream_bandwidth)) with its one constant: it reads no
/// engine's layout and no `real`.
pub fn stream_copy_source() -> String {
    format!("const STREAM_WORKGROUP_SIZE: u32 = {STREAM_WORKGROUP_SIZE}u;\n{}", include_str!("../../shaders/stream_copy.wgsl"))
}

/// The dimension-free helpers of `shaders/math.wgsl` (`is_finite`, `two_sum`, `sin_cos`), for an engine's
/// kernels after its prelude, which includes [`math_constants`].
pub const MATH: &str = include_str!("../../shaders/math.wgsl");

/// The constants `shaders/math.wgsl` reads, for an engine's prelude.
///
/// FINITE_MAX: the largest magnitude `is_finite` takes as finite, a little under each precision's
/// largest value (f64 kernels held the work of a step to f32's, and a value of 1.6e39 was
/// reported as not finite); `exponent_finite`, the bit test of NaN and ±∞ it adds in f32.
///
/// PIO2_1 + PIO2_2 + PIO2_3 is π/2 split for `sin_cos`'s reduction θ − k·π/2 (Cody–Waite): each
/// part has few enough bits that k times it is exact (see the 2D prelude, `udec::gpu::shaders`).
pub fn math_constants(precision: Precision) -> String {
    let finite_max = match precision {
        Precision::F32 => "1.0e38",
        Precision::F64 => "1.0e300",
    };
    let (pio2_1, pio2_2, pio2_3) = match precision {
        Precision::F32 => ("1.5703125", "4.837512969970703125e-4", "7.54978995489188216e-8"),
        Precision::F64 => ("1.57079632673412561417e+00", "6.07710050650619224932e-11", "0.0"),
    };
    // In f32 `is_finite` also reads the exponent's bits: a GL compiler may take NaN and ±∞ for
    // impossible and fold `abs(x) <= FINITE_MAX` to true (llvmpipe through GL let a NaN
    // orientation through, tests/suite/d3_gpu.rs), which a bit test it cannot fold away.
    let exponent = match precision {
        Precision::F32 => "fn exponent_finite(x: real) -> bool {\n    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;\n}\n",
        Precision::F64 => "fn exponent_finite(x: real) -> bool {\n    return true;\n}\n",
    };
    format!(
        "const PIO2_1: real = {pio2_1};\nconst PIO2_2: real = {pio2_2};\nconst PIO2_3: real = {pio2_3};\nconst FINITE_MAX: real = {finite_max};\n{exponent}"
    )
}

/// Parses and validates WGSL with naga, with f64 allowed only in the f64 variant. Returns the
/// module (for layout checks) or the error rendered with its source location.
pub fn validate(source: &str, precision: Precision) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    let mut caps = naga::valid::Capabilities::empty();
    if precision == Precision::F64 {
        caps |= naga::valid::Capabilities::FLOAT64;
    }
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps).validate(&module).map_err(|e| e.emit_to_string(source))?;
    Ok((module, info))
}

pub(crate) fn uniform(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

pub(crate) fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only }, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// A bind group layout of `entries` and the pipeline layout of it alone.
pub(crate) fn layouts(device: &wgpu::Device, label: &str, entries: &[wgpu::BindGroupLayoutEntry]) -> (wgpu::BindGroupLayout, wgpu::PipelineLayout) {
    let group = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries });
    let pipeline =
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some(label), bind_group_layouts: &[Some(&group)], immediate_size: 0 });
    (group, pipeline)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `workgroup_index` (layout.wgsl) numbers the workgroups of a `dispatch_grid` as
    /// y·GROUPS_PER_ROW + x: every workgroup of 0..groups exactly once, whatever the grid's rows.
    #[test]
    fn a_grid_numbers_each_workgroup_once() {
        for groups in [1, 2, 1000, MAX_GROUPS_PER_DIMENSION - 1, MAX_GROUPS_PER_DIMENSION, MAX_GROUPS_PER_DIMENSION + 1, 3 * MAX_GROUPS_PER_DIMENSION + 17] {
            let (x, y) = dispatch_grid(groups);
            assert!(x <= MAX_GROUPS_PER_DIMENSION && y <= MAX_GROUPS_PER_DIMENSION, "{groups}: grid ({x}, {y})");
            let mut seen = vec![false; (x * y) as usize];
            for wy in 0..y {
                for wx in 0..x {
                    let i = (wy * MAX_GROUPS_PER_DIMENSION + wx) as usize;
                    assert!(!seen[i], "{groups}: workgroup {i} twice");
                    seen[i] = true;
                }
            }
            assert!(seen.iter().take(groups as usize).all(|&s| s), "{groups}: a workgroup below the count is missing");
        }
    }

    /// The yardstick's kernel is valid WGSL in either precision's validator.
    #[test]
    fn the_stream_kernel_validates() {
        for p in [Precision::F32, Precision::F64] {
            validate(&stream_copy_source(), p).unwrap_or_else(|e| panic!("stream_copy ({p}): {e}"));
        }
    }
}
