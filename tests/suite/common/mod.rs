//! One scenario suite, every backend (STYLE.md item 8): each scene is written once as a function
//! taking a `Target`, and `every_backend!` generates one test per scene and backend — CPU (f64),
//! Vulkan f32, Vulkan f64, GL f32 (the best adapter of each API). Whether a GPU target is there
//! is decided by the library's `gpu::find_target`, the check behind `gpu::scenario_backends`
//! (the rows of `blockdem verify`). On a machine without that adapter a GPU test prints that it
//! skipped; with `BLOCKDEM_REQUIRE_GPU=1` (CI, where Mesa's lavapipe and llvmpipe are installed)
//! it fails instead.
#![allow(dead_code)]

pub mod voxels;

use blockdem::udec::backend::Backend;
use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::gpu::{find_target, AdapterChoice, GpuBackend, GpuOptions, Precision};

/// A `Write` that appends to a shared buffer, to read the run log back.
#[derive(Clone, Default)]
pub struct SharedLog(pub std::rc::Rc<std::cell::RefCell<Vec<u8>>>);

impl std::io::Write for SharedLog {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The GPU targets of `every_backend!` (its modules `vulkan_f32`, `vulkan_f64`, `gl_f32`).
pub const GPU_TARGETS: [(&str, Precision); 3] = [("vulkan", Precision::F32), ("vulkan", Precision::F64), ("gl", Precision::F32)];

/// The options of each GPU target present (Vulkan f32 and f64, GL f32): what the D3 tests open
/// their backend with. Under `BLOCKDEM_REQUIRE_GPU=1` a target absent is a failure, not a skip
/// (`Target::gpu`).
pub fn gpu_options() -> Vec<GpuOptions> {
    GPU_TARGETS
        .into_iter()
        .filter_map(|(api, p)| match Target::gpu(api, p) {
            Some(Target::Gpu(o)) => Some(o),
            _ => None,
        })
        .collect()
}

/// Where a scene runs.
#[derive(Clone, Debug)]
pub enum Target {
    Cpu,
    Gpu(GpuOptions),
}

impl Target {
    /// A GPU target if its adapter is present; otherwise None after saying so (or a panic under
    /// `BLOCKDEM_REQUIRE_GPU=1`).
    pub fn gpu(adapter: &str, precision: Precision) -> Option<Target> {
        let choice: AdapterChoice = adapter.parse().unwrap();
        if let Some(found) = find_target(&choice, precision) {
            return Some(Target::Gpu(found.options));
        }
        let what = format!("no {adapter} adapter with compute shaders{}", if precision == Precision::F64 { " and SHADER_F64" } else { "" });
        if std::env::var("BLOCKDEM_REQUIRE_GPU").is_ok_and(|v| v == "1") {
            panic!("BLOCKDEM_REQUIRE_GPU=1 but {what} was found (install mesa-vulkan-drivers libvulkan1 libegl1 libegl-mesa0 libgl1-mesa-dri)");
        }
        eprintln!("skipped: {what}");
        None
    }

    pub fn backend(&self) -> Box<dyn Backend> {
        match self {
            Target::Cpu => Box::new(CpuBackend::new()),
            Target::Gpu(o) => Box::new(GpuBackend::new(o).unwrap_or_else(|e| panic!("{e}"))),
        }
    }

    /// Runs a deck to its end on this target; a failure names the target.
    pub fn run(&self, deck: &str) -> blockdem::udec::model::Model {
        blockdem::scenes::run_deck_on(deck, self.backend()).unwrap_or_else(|e| panic!("deck failed on {}: {e}", self.name()))
    }

    /// True for single-precision kernels (tolerances widen to f32 round-off).
    pub fn is_f32(&self) -> bool {
        matches!(self, Target::Gpu(GpuOptions { precision: Precision::F32, .. }))
    }

    pub fn name(&self) -> String {
        match self {
            Target::Cpu => "cpu".into(),
            Target::Gpu(o) => format!("{:?} {}", o.adapter, o.precision),
        }
    }
}

#[allow(unused_macros)]
/// Generates, for each scene function `fn scene(t: &Target)`, one test per backend, in modules
/// `cpu`, `vulkan_f32`, `vulkan_f64`, `gl_f32`.
macro_rules! every_backend {
    ($($scene:ident),* $(,)?) => {
        mod cpu {
            $( #[test] fn $scene() { super::$scene(&crate::common::Target::Cpu) } )*
        }
        mod vulkan_f32 {
            $( #[test] fn $scene() { if let Some(t) = crate::common::Target::gpu("vulkan", blockdem::udec::gpu::Precision::F32) { super::$scene(&t) } } )*
        }
        mod vulkan_f64 {
            $( #[test] fn $scene() { if let Some(t) = crate::common::Target::gpu("vulkan", blockdem::udec::gpu::Precision::F64) { super::$scene(&t) } } )*
        }
        mod gl_f32 {
            $( #[test] fn $scene() { if let Some(t) = crate::common::Target::gpu("gl", blockdem::udec::gpu::Precision::F32) { super::$scene(&t) } } )*
        }
    };
}
#[allow(unused_imports)]
pub(crate) use every_backend;

/// A legacy VTK file of `output::vtk` read back with vtkio: its points (x, y, z each), its
/// cells' vertex lists (`n i1 … in` each) and its point or cell arrays by name, as f64.
pub struct VtkFrame {
    pub points: Vec<f64>,
    pub cells: Vec<u32>,
    pub arrays: Vec<(String, Vec<f64>)>,
}

impl VtkFrame {
    pub fn read(path: &std::path::Path) -> VtkFrame {
        use vtkio::model::{Attribute, DataSet, Piece, VertexNumbers};
        let vtk = vtkio::Vtk::import(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let DataSet::PolyData { pieces, .. } = vtk.data else { panic!("{}: not poly data", path.display()) };
        let Some(Piece::Inline(piece)) = pieces.into_iter().next() else { panic!("{}: no inline piece", path.display()) };
        let cells = match piece.polys.or(piece.verts) {
            Some(VertexNumbers::Legacy { vertices, .. }) => vertices,
            other => panic!("{}: cells {other:?}", path.display()),
        };
        let arrays = piece
            .data
            .point
            .into_iter()
            .chain(piece.data.cell)
            .filter_map(|a| match a {
                Attribute::DataArray(d) => Some((d.name, d.data.cast_into::<f64>().expect("numbers"))),
                Attribute::Field { .. } => None,
            })
            .collect();
        VtkFrame { points: piece.points.cast_into::<f64>().expect("points"), cells, arrays }
    }

    pub fn array(&self, name: &str) -> &[f64] {
        &self.arrays.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no array {name}")).1
    }
}

/// xorshift64*: deterministic random numbers without a dependency.
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next() * n as f64) as u32).min(n - 1)
    }
}

/// Runs a deck on the CPU; returns the result and the run log.
pub fn run_logged(deck: &str) -> (Result<blockdem::udec::model::Model, blockdem::udec::exec::RunError>, String) {
    let log = SharedLog::default();
    let r = blockdem::scenes::run_deck_logged(deck, Box::new(CpuBackend::new()), Box::new(log.clone()));
    let text = String::from_utf8(log.0.borrow().clone()).unwrap();
    (r, text)
}

/// `run_logged` of a deck that must run: the model and the log (a failure panics with both).
pub fn run_ok(deck: &str) -> (blockdem::udec::model::Model, String) {
    let (r, log) = run_logged(deck);
    match r {
        Ok(m) => (m, log),
        Err(e) => panic!("deck failed: {e}\n{log}"),
    }
}

/// The text of the sample deck `name` in examples/.
pub fn sample(name: &str) -> String {
    let path = format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Runs `entry` of the WGSL `src` (validated by the caller) over `cases` invocations (workgroups
/// of 64) with the given buffers (binding, bytes, is_output) bound in group 0; returns the
/// outputs' bytes in order. The kernel tests' harness (tests/suite/gpu_kernels.rs,
/// d3_crack_gpu.rs).
pub fn run_wgsl(dev: &blockdem::gpu::GpuDevice, src: &str, entry: &str, cases: usize, buffers: &[(u32, Vec<u8>, bool)]) -> Vec<Vec<u8>> {
    let device = &dev.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(entry), source: wgpu::ShaderSource::Wgsl(src.into()) });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    });
    let bufs: Vec<wgpu::Buffer> = buffers
        .iter()
        .map(|(b, bytes, _)| {
            let buf = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&format!("binding {b}")),
                size: bytes.len().max(16) as u64,
                // UNIFORM too: a kernel's constants (binding 0 of list_blocks.wgsl) are a uniform.
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            dev.queue.write_buffer(&buf, 0, bytes);
            buf
        })
        .collect();
    let entries: Vec<wgpu::BindGroupEntry> =
        buffers.iter().zip(&bufs).map(|((b, _, _), buf)| wgpu::BindGroupEntry { binding: *b, resource: buf.as_entire_binding() }).collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(entry), layout: &pipeline.get_bind_group_layout(0), entries: &entries });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(entry), timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((cases as u32).div_ceil(64), 1, 1);
    }
    dev.queue.submit([enc.finish()]);
    buffers.iter().zip(&bufs).filter(|((_, _, out), _)| *out).map(|((_, bytes, _), buf)| dev.read_buffer(buf, bytes.len() as u64).unwrap()).collect()
}

/// A D3 wall of twenty bricks (two courses of ten, [`d3_brick_courses`]) on a fixed slab under
/// gravity, and a 0.5 m cube `off` m in front of its face (y = 0) moving at 10 m/s towards it,
/// at FRACTION `fraction`; no CYCLE. At FRACTION 0.1 the bricks' step is ~3.3 µs, so the cube
/// strikes at cycle ~300 per centimetre off.
pub fn d3_struck_wall(off: f64, fraction: f64) -> String {
    let mut deck = String::from("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6\nBOX -1 5.2 -1 1.2 -1 0\n");
    deck += &d3_brick_courses(2, 10);
    deck += &format!("BOX 1.85 2.35 {} {} 0.05 0.55\nFIX -0.5 4.7 -0.5 0.7 -0.6 -0.4\nGRAV 0 0 -10\n", -0.5 - off, -off);
    deck += &format!("VELOCITY 1.8 2.4 {} {} 0 0.6 0 10 0\nFRACTION {fraction}\n", -0.6 - off, -0.5 * off);
    deck
}

/// A D3 deck's BOX lines for `courses` courses of `per_course` bricks 0.4 × 0.2 × 0.2 m in
/// running bond (every other course shifted half a brick), the first course on z = 0.
pub fn d3_brick_courses(courses: usize, per_course: usize) -> String {
    let mut deck = String::new();
    for course in 0..courses {
        let shift = if course % 2 == 1 { 0.2 } else { 0.0 };
        for k in 0..per_course {
            let (x, z) = (shift + 0.4 * k as f64, 0.2 * course as f64);
            deck += &format!("BOX {x:.3} {:.3} 0 0.2 {z:.3} {:.3}\n", x + 0.4, z + 0.2);
        }
    }
    deck
}
