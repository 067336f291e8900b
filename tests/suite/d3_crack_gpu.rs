//! Griffith's cracking on the D3 GPU backend (`d3::gpu`, "Cracking on the device"): the screen
//! each simply-deformable candidate evaluates in the strain stage (sdef.wgsl's `griffith_screen`,
//! twin `sdef::griffith_screen`), the batch halted by `end_cycle` (twin `d3::gpu::end_cycle`) at
//! the cycle a screen fires, and the CPU's exact check after it. On Vulkan f32 and f64 and GL f32
//! (lavapipe and llvmpipe here; skipped without the adapter, a failure under
//! `BLOCKDEM_REQUIRE_GPU=1`). The column that cracks at the CPU's cycle in batches is
//! tests/suite/d3_gpu.rs's `a_deformable_column_cracks_on_the_gpu_at_the_cpus_cycle`.

use crate::common;

use blockdem::d3::backend::Backend as _;
use blockdem::d3::cpu::CpuBackend;
use blockdem::d3::exec::Executor;
use blockdem::d3::gpu::layout::{Halt, SdefBlock};
use blockdem::d3::gpu::{end_cycle, shaders, GpuBackend};
use blockdem::d3::model::Model;
use blockdem::d3::sdef;
use blockdem::gpu::real::Real;
use blockdem::gpu::{wgsl, GpuDevice};
use blockdem::udec::gpu::{GpuOptions, Precision};
use common::Rng;
use glam::{DMat3, DQuat, DVec3};

/// A device for each GPU target present (Vulkan f32 and f64, GL f32).
fn devices() -> Vec<(GpuOptions, GpuDevice)> {
    common::gpu_options()
        .into_iter()
        .map(|o| {
            let dev = GpuDevice::open(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
            (o, dev)
        })
        .collect()
}

/// Runs `entry` of `snippet`, appended to the strain stage's source (`d3::gpu::shaders`, with
/// `end_cycle`'s bindings where `with_end_cycle`), over `cases` invocations with the given
/// buffers (binding, bytes, is_output); returns the outputs in order.
fn run_snippet(dev: &GpuDevice, with_end_cycle: bool, snippet: &str, entry: &str, cases: usize, buffers: &[(u32, Vec<u8>, bool)]) -> Vec<Vec<u8>> {
    let base = if with_end_cycle {
        shaders::end_cycle_source(dev.precision)
    } else {
        format!("{}\n{}\n{}\n{}\n{}", shaders::prelude(dev.precision, true, false), wgsl::MATH, shaders::LAYOUT, shaders::SDEF, shaders::COMMON)
    };
    let src = format!("{base}\n{snippet}");
    wgsl::validate(&src, dev.precision).unwrap_or_else(|e| panic!("{e}"));
    crate::common::run_wgsl(dev, &src, entry, cases, buffers)
}

const SCREEN: &str = r#"
@group(0) @binding(20) var<storage, read> t_in: array<real>;
@group(0) @binding(21) var<storage, read_write> t_out: array<u32>;

@compute @workgroup_size(64)
fn test_griffith_screen(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&t_out)) {
        return;
    }
    var s: SdefBlock;
    s.s0 = t_in[7u * i];
    s.s1 = t_in[7u * i + 1u];
    s.s2 = t_in[7u * i + 2u];
    s.s3 = t_in[7u * i + 3u];
    s.s4 = t_in[7u * i + 4u];
    s.s5 = t_in[7u * i + 5u];
    s.tf = t_in[7u * i + 6u];
    t_out[i] = select(0u, 1u, griffith_screen(s));
}
"#;

/// The exact check's value on a stress as the CPU reads it back (`cracking::due`).
fn griffith_value(stress: [f64; 6]) -> f64 {
    let (p, _) = sdef::principal_stresses(stress);
    sdef::griffith_stress(p[0], p[2])
}

/// A stress with principal values `values` along a random frame, as the kernel precision `R`
/// holds it (Voigt: 11, 22, 33, 12, 13, 23).
fn stress_in<R: Real>(rng: &mut Rng, values: [f64; 3]) -> [f64; 6] {
    let axis = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
    let q = if axis.length() > 1e-3 { DQuat::from_axis_angle(axis.normalize(), rng.range(0.0, 6.3)) } else { DQuat::IDENTITY };
    let r = DMat3::from_quat(q);
    let t = r * DMat3::from_diagonal(DVec3::from_array(values)) * r.transpose();
    sdef::voigt(t).map(|x| R::from_f64(x).to_f64())
}

/// Stresses that reach Griffith's criterion in every way the exact check is hard on: random,
/// a double major or minor principal stress (the CPU's arccosine at its ill-conditioned ends),
/// nearly hydrostatic (a small deviator on a large mean), uniaxial, and on the axes.
fn stresses<R: Real>(rng: &mut Rng) -> Vec<[f64; 6]> {
    let mut out = Vec::new();
    for k in 0..4000 {
        let scale = 10f64.powf(rng.range(2.0, 8.0));
        let (a, b, c) = (rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let values = match k % 6 {
            0 => [a, b, c],
            1 => [a, a, b],
            2 => [a, b, b],
            3 => [a, a * (1.0 + 1e-7 * b), c],
            4 => [-3.0 + 1e-4 * a, -3.0 + 1e-4 * b, -3.0 + 1e-4 * c],
            _ => [0.0, 0.0, -a.abs()],
        }
        .map(|v| v * scale);
        let s = if k % 50 == 0 {
            sdef::voigt(DMat3::from_diagonal(DVec3::from_array(values))).map(|x| R::from_f64(x).to_f64())
        } else {
            stress_in::<R>(rng, values)
        };
        if griffith_value(s) > 0.0 {
            out.push(s);
        }
    }
    out
}

fn norm(s: [f64; 6]) -> f64 {
    (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5])).sqrt()
}

/// The kernel's screen against the CPU's exact check on the same (rounded) stresses: with TF at
/// the exact value (the CPU cracks the block) the screen fires, every time; with TF three margins
/// above it (`shaders::griffith_margin`) it does not, so the screen is that tight. Also the f64
/// Rust twin, on the CPU.
fn screen_matches<R: Real>(dev: &GpuDevice) {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let cases = stresses::<R>(&mut rng);
    let margin = shaders::griffith_margin(R::PRECISION);
    let mut input = Vec::new();
    let mut expected = Vec::new();
    for s in &cases {
        let v = griffith_value(*s);
        for (tf, fires) in [(v, true), (v + 3.0 * margin * norm(*s), false)] {
            // TF as the kernel holds it, rounded down where it must fire (the CPU compares with
            // the f64 TF, the kernel with its rounding).
            let tf_r = R::from_f64(tf).to_f64();
            let tf_r = if fires && tf_r > tf { f64::from_bits(tf_r.to_bits() - 1).min(tf) } else { tf_r };
            input.extend(s.iter().copied().chain([tf_r]));
            expected.push(fires);
            if R::PRECISION == Precision::F64 {
                assert_eq!(sdef::griffith_screen(*s, tf, margin), fires, "the Rust twin on {s:?}, TF {tf} (exact {v})");
            }
        }
    }
    let bytes: Vec<u8> = input.iter().flat_map(|&x| bytemuck::bytes_of(&R::from_f64(x)).to_vec()).collect();
    let out = run_snippet(dev, false, SCREEN, "test_griffith_screen", expected.len(), &[(20, bytes, false), (21, vec![0u8; 4 * expected.len()], true)]);
    let fired: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
    let missed = expected.iter().zip(&fired).filter(|(&e, &f)| e && f == 0).count();
    let early = expected.iter().zip(&fired).filter(|(&e, &f)| !e && f != 0).count();
    eprintln!("{:?}: {} stresses, {missed} cracks missed, {early} screens fired three margins below TF", R::PRECISION, cases.len());
    assert_eq!(missed, 0, "{:?}: the screen missed a crack the exact check finds", R::PRECISION);
    assert_eq!(early, 0, "{:?}: the screen fired three margins below TF", R::PRECISION);
}

#[test]
fn the_griffith_screen_never_misses_a_crack_and_is_tight() {
    for (o, dev) in devices() {
        match o.precision {
            Precision::F32 => screen_matches::<f32>(&dev),
            Precision::F64 => screen_matches::<f64>(&dev),
        }
    }
}

/// `end_cycle` against its Rust twin: a quiet cycle is counted and the grids stay; a cycle whose
/// screen fired is counted and halts the batch, every grid zeroed; a halted batch's cycle is not
/// counted and changes nothing.
#[test]
fn end_cycle_halts_the_batch_as_its_twin() {
    for (o, dev) in devices() {
        if o.precision != Precision::F32 {
            continue;
        }
        let blocks = 2u32;
        let start = Halt { cycles_done: 4, ..Halt::start((3, 1), (3, 1), (65535, 2)) };
        let halted = Halt { cycles_done: 4, halted: 1, ..Default::default() };
        for (before, flag) in [(start, 0), (start, 1), (halted, 1), (halted, 0)] {
            let mut strain = vec![SdefBlock::<f32>::default(); blocks as usize + 1];
            strain[blocks as usize].spare = flag;
            let params = blockdem::d3::gpu::layout::Params::<f32> { blocks, ..Default::default() };
            let out = run_snippet(
                &dev,
                true,
                "",
                "end_cycle",
                1,
                &[
                    (0, bytemuck::bytes_of(&params).to_vec(), false),
                    (8, bytemuck::cast_slice(&strain).to_vec(), false),
                    (9, bytemuck::bytes_of(&before).to_vec(), true),
                ],
            );
            let gpu: Halt = bytemuck::pod_read_unaligned(&out[0]);
            let mut rust = before;
            end_cycle(&mut rust, flag);
            assert_eq!(gpu, rust, "{:?}: end_cycle of {before:?} with the flag {flag}", o.adapter);
        }
        let mut h = start;
        end_cycle(&mut h, 1);
        assert_eq!((h.cycles_done, h.halted, h.gather_x, h.track_contact_y), (5, 1, 0, 0));
    }
}

/// A scene of two blocks at rest without gravity: a fixed simply-deformable block (constitutive
/// 3, Griffith's law) under a constant uniaxial compression of 16 kPa, whose Griffith stress is
/// σc/8 = 2 kPa exactly in both precisions, and a free rigid block far from it; TF `tf`.
fn loaded_block(tf: &str) -> Model {
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nPROP MAT=2 D=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 TF={tf}\nBOX 0 1 0 1 0 2 MAT 2 CONS 3\nBOX 5 6 5 6 0 1\n\
         CHANGE 0 1 0 1 0 2 SDEF\nFIX 0 1 0 1 0 2\n"
    );
    let commands = blockdem::d3::deck::parse_deck(&deck, "<test>").unwrap();
    let mut exec = Executor::new(Box::new(std::io::sink()), "<test>");
    exec.run(&commands).unwrap_or_else(|e| panic!("{e}"));
    let mut model = std::mem::take(&mut exec.model);
    let mat = model.material(2);
    let (lambda, g) = (sdef::lame_lambda(mat.bulk, mat.shear), mat.shear);
    let stress = [0.0, 0.0, -16000.0, 0.0, 0.0, 0.0];
    // The strain of that stress (isotropic compliance), so that the state is an elastic one.
    let mean = lambda * stress[2] / (2.0 * g * (3.0 * lambda + 2.0 * g));
    let strain = [-mean, -mean, stress[2] / (2.0 * g) - mean, 0.0, 0.0, 0.0];
    let b = &mut model.blocks[0];
    let s = b.sdef.as_mut().expect("simply deformable");
    (s.stress, s.strain) = (stress, strain);
    b.place_vertices();
    assert_eq!(griffith_value(stress), 2000.0);
    model
}

/// Where the screen fires but the exact check says no (TF a millionth above the block's Griffith
/// stress: within both precisions' margins), every batch halts after its first cycle, the CPU
/// finds no crack, and the run goes on to its end; with TF 1% above the stress the batches run
/// through; with TF at the stress the block cracks after the first cycle, as on the CPU.
#[test]
fn a_screen_that_fires_below_tf_lets_the_run_go_on() {
    const CYCLES: u64 = 60;
    let mut cpu = CpuBackend::new();
    for o in common::gpu_options() {
        let mut gpu = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
        // Just under TF: halted each cycle, no crack.
        let mut m = loaded_block("2000.002");
        let before = gpu.batches();
        let report = gpu.run(&mut m, CYCLES, &mut |_| true).unwrap_or_else(|e| panic!("{e}"));
        let batches = gpu.batches() - before;
        assert!(report.cracks.is_empty() && m.blocks.len() == 2 && m.cycle == CYCLES, "{:?}: {:?}", o.precision, report.cracks);
        // The batches halted after each cycle (they shrink to two cycles, of which one runs).
        assert_eq!(batches, CYCLES, "{:?}: the screen fired each cycle", o.precision);
        // Well under TF: batches as long as the energy checks allow.
        let mut m = loaded_block("2020");
        let before = gpu.batches();
        let report = gpu.run(&mut m, CYCLES, &mut |_| true).unwrap();
        assert!(report.cracks.is_empty() && m.cycle == CYCLES);
        assert_eq!(gpu.batches() - before, 1, "{:?}: one batch of {CYCLES} cycles", o.precision);
        // At TF: cracked after the first cycle, as on the CPU.
        let mut m = loaded_block("2000");
        let report = gpu.run(&mut m, 3, &mut |_| true).unwrap();
        let mut c = loaded_block("2000");
        let cpu_report = cpu.run(&mut c, 3, &mut |_| true).unwrap();
        let cycles = |r: &blockdem::driver::CycleReport| r.cracks.iter().map(|c| (c.cycle, c.block, c.new_block)).collect::<Vec<_>>();
        assert_eq!(cycles(&report), vec![(1, 1, 3)], "{:?}", o.precision);
        assert_eq!(cycles(&report), cycles(&cpu_report), "{:?}: the CPU's cracks", o.precision);
        assert_eq!(m.blocks.len(), c.blocks.len());
    }
}
