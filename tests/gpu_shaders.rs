//! Shaders are checked without a GPU (STYLE.md item 9): every kernel file in every precision
//! parses and validates with naga, and every GPU struct's size and field offsets, read through
//! naga's type layouter, equal its Rust twin in src/gpu/layout.rs.

use blockdem::gpu::layout::{self, Real, StructLayout};
use blockdem::gpu::shaders;
use blockdem::gpu::Precision;

#[test]
fn every_kernel_parses_and_validates_in_every_precision() {
    for precision in [Precision::F32, Precision::F64] {
        for name in shaders::kernel_names() {
            let src = shaders::source(name, precision).unwrap();
            let (module, _) = shaders::validate(&src, precision).unwrap_or_else(|e| panic!("{name}.wgsl ({precision}):\n{e}"));
            assert!(module.entry_points.iter().any(|e| e.name == name), "{name}.wgsl has an entry point named after it");
        }
    }
}

#[test]
fn f64_kernels_need_the_f64_capability() {
    // The f64 variant really is f64: without the FLOAT64 capability naga rejects it.
    let src = shaders::source("law_of_motion", Precision::F64).unwrap();
    let module = naga::front::wgsl::parse_str(&src).unwrap();
    let strict = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty()).validate(&module);
    assert!(strict.is_err());
}

fn naga_layout(module: &naga::Module, name: &str) -> StructLayout {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let (handle, ty) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).unwrap_or_else(|| panic!("no WGSL struct {name}"));
    let naga::TypeInner::Struct { members, span } = &ty.inner else { panic!("{name} is not a struct") };
    let size = layouter[handle].size;
    assert_eq!(size, *span);
    StructLayout {
        name: layout::layouts::<f32>().into_iter().find(|l| l.name == name).unwrap().name,
        size: size as usize,
        fields: members.iter().map(|m| (leak(m.name.clone().unwrap()), m.offset as usize)).collect(),
    }
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

fn check_layouts<R: Real>(precision: Precision) {
    let src = shaders::source("contact_forces", precision).unwrap();
    let (module, _) = shaders::validate(&src, precision).unwrap();
    for rust in layout::layouts::<R>() {
        let wgsl = naga_layout(&module, rust.name);
        assert_eq!(wgsl, rust, "{} in {precision}: WGSL (left) against Rust (right)", rust.name);
    }
}

#[test]
fn every_gpu_struct_matches_its_rust_twin_in_f32() {
    check_layouts::<f32>(Precision::F32);
}

#[test]
fn every_gpu_struct_matches_its_rust_twin_in_f64() {
    check_layouts::<f64>(Precision::F64);
}
