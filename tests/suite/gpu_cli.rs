//! The GPU options of the `blockdem` binary: `adapters`, `--backend gpu|auto`, `--adapter`,
//! `--precision`, and their errors.

use crate::common;

use std::process::Command;

use blockdem::udec::gpu::Precision;
use common::Target;

fn blockdem(args: &[&str], env: &[(&str, &str)]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_blockdem")).args(args).envs(env.iter().copied()).output().expect("runs");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn sample_1() -> String {
    format!("{}/examples/udec1_point_load_cracking.dat", env!("CARGO_MANIFEST_DIR"))
}

fn out_dir(name: &str) -> String {
    let d = std::env::temp_dir().join(format!("blockdem-gpu-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d.display().to_string()
}

#[test]
fn adapters_lists_backend_driver_limits_and_f64() {
    if Target::gpu("vulkan", Precision::F32).is_none() {
        return;
    }
    let (code, stdout, stderr) = blockdem(&["adapters"], &[]);
    assert_eq!(code, 0, "{stderr}");
    for key in [
        "Vulkan",
        "driver:",
        "max_storage_buffers_per_shader_stage",
        "max_storage_buffer_binding_size",
        "max_buffer_size",
        "max_compute_workgroup_size_x",
        "SHADER_F64",
    ] {
        assert!(stdout.contains(key), "{key} missing:\n{stdout}");
    }
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "headless Mesa stays quiet: {stderr}");
    // A driver that gives no name (Mesa's GL adapter) is said to, not shown as nothing.
    assert!(!stdout.contains("driver:  (") && !stdout.contains("driver: ()"), "{stdout}");
}

/// Issue 27 item 9: the GL adapter's empty driver name showed as `[]` in "running on".
#[test]
fn an_adapter_without_a_driver_name_is_described_sensibly() {
    if Target::gpu("gl", Precision::F32).is_none() {
        return;
    }
    let out = out_dir("gl-driver");
    let (code, stdout, stderr) = blockdem(&["run", &sample_1(), "--backend", "gpu", "--adapter", "gl", "--out", &out], &[]);
    assert_eq!(code, 0, "{stderr}");
    let running = stderr.lines().find(|l| l.contains("running on gpu (")).unwrap_or_else(|| panic!("{stderr}"));
    assert!(!running.contains("[]"), "{running}");
    let provenance = stdout.lines().find(|l| l.starts_with("BLOCKDEM ")).unwrap_or_else(|| panic!("{stdout}"));
    assert!(!provenance.contains(", )") && provenance.contains("PRECISION f32"), "{provenance}");
}

#[test]
fn sample_1_runs_on_the_gpu_backend_from_the_command_line() {
    if Target::gpu("vulkan", Precision::F32).is_none() {
        return;
    }
    let out = out_dir("sample1");
    let (code, stdout, stderr) = blockdem(&["run", &sample_1(), "--backend", "gpu", "--adapter", "vulkan", "--out", &out], &[]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("running on gpu (Vulkan"), "{stderr}");
    assert_eq!(stdout.matches("CRACKED AT CYCLE").count(), 1, "{stdout}");
    // The log itself says it came from the GPU in f32, and on which adapter (issue 27 item 8).
    let provenance = stdout.lines().find(|l| l.starts_with("BLOCKDEM ")).unwrap_or_else(|| panic!("no provenance line:\n{stdout}"));
    assert!(provenance.contains("  BACKEND gpu  ADAPTER ") && provenance.contains("(Vulkan, ") && provenance.contains("  PRECISION f32  "), "{provenance}");
}

#[test]
fn f64_on_an_adapter_without_it_is_a_clear_error() {
    if Target::gpu("gl", Precision::F32).is_none() {
        return;
    }
    let (code, _, stderr) = blockdem(&["run", &sample_1(), "--backend", "gpu", "--adapter", "gl", "--precision", "f64", "--out", &out_dir("f64")], &[]);
    assert_ne!(code, 0);
    assert!(stderr.contains("SHADER_F64") && stderr.contains("--precision f32"), "{stderr}");
    assert!(stderr.contains("--adapter gl finds only llvmpipe") && stderr.contains("(Gl)"), "names the adapter found: {stderr}");
    // Chosen through WGPU_BACKEND, the adapter is named as found, not as the choice `Any`.
    let (code, _, stderr) = blockdem(&["run", &sample_1(), "--backend", "gpu", "--precision", "f64", "--out", &out_dir("f64env")], &[("WGPU_BACKEND", "gl")]);
    assert_ne!(code, 0);
    assert!(stderr.contains("--adapter any with WGPU_BACKEND=gl finds only") && stderr.contains("(Gl)") && !stderr.contains("(Any)"), "{stderr}");
    // The benchmark says the same instead of "no GPU adapter found".
    let (code, _, stderr) = blockdem(&["bench", "--quick", "--backend", "gpu", "--adapter", "gl", "--precision", "f64", "--out", &out_dir("f64bench")], &[]);
    assert_ne!(code, 0);
    assert!(stderr.contains("needs SHADER_F64") && stderr.contains("(Gl)") && !stderr.contains("no GPU adapter found"), "{stderr}");
}

#[test]
fn an_unknown_adapter_name_is_an_error_for_gpu_and_a_fallback_for_auto() {
    let (code, _, stderr) = blockdem(&["run", &sample_1(), "--backend", "gpu", "--adapter", "no-such-adapter", "--out", &out_dir("name")], &[]);
    assert_ne!(code, 0);
    assert!(stderr.contains("no GPU adapter") && stderr.contains("no-such-adapter"), "{stderr}");
    let (code, _, stderr) = blockdem(&["run", &sample_1(), "--backend", "auto", "--adapter", "no-such-adapter", "--out", &out_dir("auto")], &[]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(stderr.lines().filter(|l| l.contains("running on the CPU")).count(), 1, "one line says so: {stderr}");
}

#[test]
fn wgpu_backend_env_is_honoured() {
    if Target::gpu("gl", Precision::F32).is_none() {
        return;
    }
    let (code, _, stderr) = blockdem(&["run", &sample_1(), "--backend", "gpu", "--out", &out_dir("env")], &[("WGPU_BACKEND", "gl")]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("running on gpu (Gl"), "{stderr}");
}

#[test]
fn f32_kernels_warn_against_their_own_extreme_ratio_limits() {
    // A light block (mass ratio 1e5) on a heavy one: within the CPU's verified limits (1e6), beyond
    // the f32 kernels' (1e4, as far as the suite tries a GPU): the warning comes before the run
    // on the f32 GPU backend only.
    if Target::gpu("vulkan", Precision::F32).is_none() {
        return;
    }
    let dir = out_dir("f32limits");
    std::fs::create_dir_all(&dir).unwrap();
    let deck = format!("{dir}/ratio.dat");
    std::fs::write(
        &deck,
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nPROP MAT=2 D=0.02 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 4,1 4,0\n\
         BLOCK 1,1 1,2 2,2 2,1\nBLOCK MAT=2 1,2 1,3 2,3 2,2\nFIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 10\n",
    )
    .unwrap();
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "gpu", "--adapter", "vulkan", "--precision", "f32", "--out", &dir], &[]);
    assert_eq!(code, 0, "{stderr}");
    let warn = stdout.find("WARNING: block masses range over 1.0e5").unwrap_or_else(|| panic!("no warning on f32:\n{stdout}"));
    assert!(warn < stdout.find("INITIAL TIMESTEP").unwrap());
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", &dir], &[]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!stdout.contains("WARNING"), "{stdout}");
}

#[test]
fn compare_reports_how_far_the_gpu_lies_from_the_cpu_reference() {
    // Sample 1 (one crack, the piece falling onto the base): in f64 the GPU agrees with the CPU
    // to round-off, block by block and term by term; in f32 to its own round-off, which a
    // tolerance of 1e-12 rounding lengths refuses, naming the block. Each run's log and plots
    // go to OUT/cpu and OUT/gpu, the figures to OUT/compare.json.
    if Target::gpu("vulkan", Precision::F64).is_none() {
        return;
    }
    let out = out_dir("compare");
    let (code, stdout, stderr) = blockdem(&["compare", &sample_1(), "--adapter", "vulkan", "--precision", "f64", "--out", &out, "--tolerance", "1e-9"], &[]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    for line in ["reference (cpu)", "gpu / cpu wall time", "position", "rotation", "velocity", "external work"] {
        assert!(stdout.contains(line), "{line} missing:\n{stdout}");
    }
    let out = std::path::Path::new(&out);
    for run in ["cpu", "gpu"] {
        let log = std::fs::read_to_string(out.join(run).join("run.log")).unwrap();
        assert_eq!(log.matches("CRACKED AT CYCLE").count(), 1, "{run}: {log}");
        assert!(out.join(run).join("plot_002.png").is_file(), "{run}'s plot");
    }
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("compare.json")).unwrap()).unwrap();
    let c = &json["comparison"];
    assert_eq!(c["cycles"], serde_json::json!([600, 600]));
    assert_eq!(c["blocks"][0], c["blocks"][1]);
    for q in ["position", "rotation", "velocity"] {
        let r = c[q]["relative"].as_f64().unwrap();
        assert!(r < 1e-9, "{q}: {r}");
    }
    assert!(c["energy"].as_array().unwrap().iter().all(|t| t[2].as_f64().unwrap() < 1e-12), "{}", c["energy"]);
    // f32 against a tolerance below its round-off: refused, naming a block and the quantity.
    let (code, stdout, stderr) =
        blockdem(&["compare", &sample_1(), "--adapter", "vulkan", "--out", &out.join("f32").display().to_string(), "--tolerance", "1e-12"], &[]);
    assert_ne!(code, 0, "{stdout}");
    assert!(stderr.contains("differs by") && stderr.contains("more than the tolerance 1e-12"), "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("f32").join("compare.json")).unwrap()).unwrap();
    let r = json["comparison"]["position"]["relative"].as_f64().unwrap();
    assert!(r > 1e-12 && r < 1e-3, "f32 position difference {r} of ROUND");
}

#[test]
fn compare_fails_when_only_one_run_stops() {
    // Masses of 1e40 kg run in f64 on the CPU; the f32 kernels refuse them: the comparison still
    // reports both runs, and fails naming the GPU's stop.
    if Target::gpu("vulkan", Precision::F32).is_none() {
        return;
    }
    let out = out_dir("compare-stop");
    let deck = std::path::Path::new(&out).with_extension("dat");
    std::fs::write(
        &deck,
        "START\nPROP MAT=1 D=1E40 KN=1E45 KS=1E45\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX 0 1 0 0.9\nGRAV 0 -10\nCYCLE 10\nSTOP\n",
    )
    .unwrap();
    let (code, stdout, stderr) = blockdem(&["compare", &deck.display().to_string(), "--adapter", "vulkan", "--out", &out], &[]);
    assert_ne!(code, 0, "{stdout}");
    assert!(stdout.contains("stopped: ") && stdout.contains("outside the range of the f32 kernels"), "{stdout}");
    assert!(stderr.contains("the GPU run stopped where the reference did not"), "{stderr}");
}

/// Issue 27 item 3 on the GPU: the kinetic energy VELOCITY gives is booked on the model side, so
/// the GPU's balance stays at zero too (a lone block given 10 m/s, then slowed to 2 m/s).
#[test]
fn velocity_is_booked_in_the_ledger_on_the_gpu() {
    if Target::gpu("vulkan", Precision::F32).is_none() {
        return;
    }
    let dir = out_dir("velocity-ledger");
    std::fs::create_dir_all(&dir).unwrap();
    let deck = format!("{dir}/deck.dat");
    std::fs::write(
        &deck,
        "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nVELOCITY -1 2 -1 2 10 0\nCYCLE 100\nPRINT ENERGY\n\
         VELOCITY -10 10 -10 10 2 0\nCYCLE 100\nPRINT ENERGY\n",
    )
    .unwrap();
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "gpu", "--adapter", "vulkan", "--out", &dir], &[]);
    assert_eq!(code, 0, "{stderr}");
    let balances: Vec<&str> = stdout.lines().filter(|l| l.contains("BALANCE")).collect();
    assert_eq!(balances.len(), 2, "{stdout}");
    for b in balances {
        let value: f64 = b.rsplit(' ').next().unwrap().parse().unwrap();
        // f32 kinetic energy of 5e4 J: round-off of a few parts in 1e7.
        assert!(value.abs() < 1e-3 * 5e4, "{b}");
    }
}

/// The test command runs Mesa's software adapters with `LP_NUM_THREADS=0` (scripts/test.sh): the
/// workgroups of a dispatch run one after another on the thread that submits them, which takes
/// about a third less time for the suite's small scenes on CI's two cores. The kernels' results
/// must not depend on that: with the adapter's worker threads running workgroups at once (a race
/// between workgroups, a gather whose order follows the schedule, would show here), a run's final
/// state (less the run's date) is byte for byte the serial run's, and a threaded rerun's too. Both engines, each
/// struck by its projectile (the 2D wall of 1012 bricks, D3's wall of 1000), on Vulkan f32, and
/// the 2D one on GL.
#[test]
fn gpu_runs_do_not_depend_on_the_adapters_worker_threads() {
    let dir = std::path::PathBuf::from(out_dir("threads"));
    std::fs::create_dir_all(&dir).unwrap();
    let example = std::fs::read_to_string(format!("{}/examples/brick_wall_impact.dat", env!("CARGO_MANIFEST_DIR"))).unwrap();
    assert!(example.contains("CYCLE 7072\n"), "the impact example's CYCLE line moved");
    // 300 cycles: the projectile (fired from x = -2 at 50 m/s) meets the wall's contacts from
    // its first steps' detection on; every brick's contacts are loaded by gravity.
    let decks = [
        ("wall2d", example.replace("CYCLE 7072\n", "CYCLE 300\n"), &["vulkan", "gl"][..]),
        ("wall3d", format!("{}CYCLE 60\nSTOP\n", blockdem::bench::d3::wall_deck(1000, 0.1)), &["vulkan"][..]),
    ];
    for (name, deck, adapters) in decks {
        let path = dir.join(format!("{name}.dat"));
        std::fs::write(&path, deck).unwrap();
        for &adapter in adapters {
            if Target::gpu(adapter, Precision::F32).is_none() {
                continue;
            }
            let state = |threads: &str, run: &str| {
                let json = dir.join(format!("{name}-{adapter}-{run}.json"));
                let (code, _, stderr) = blockdem(
                    &[
                        "run",
                        path.to_str().unwrap(),
                        "--backend",
                        "gpu",
                        "--adapter",
                        adapter,
                        "--out",
                        dir.to_str().unwrap(),
                        "--state-json",
                        json.to_str().unwrap(),
                    ],
                    &[("LP_NUM_THREADS", threads)],
                );
                assert_eq!(code, 0, "{name} on {adapter} with LP_NUM_THREADS={threads}: {stderr}");
                // The state less its provenance (which carries the run's date).
                let mut state: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
                assert!(state.as_object_mut().unwrap().remove("provenance").is_some());
                serde_json::to_string(&state).unwrap()
            };
            let serial = state("0", "serial");
            let threaded = state("4", "threaded");
            assert!(serial.len() > 1000 && serial == threaded, "{name} on {adapter}: the threaded run's state differs from the serial one's");
            assert!(state("3", "rerun") == threaded, "{name} on {adapter}: a threaded rerun differs");
        }
    }
}
