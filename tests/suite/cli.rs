//! The `blockdem` binary: exit status, error messages naming file and line, outputs.

use std::process::Command;

fn blockdem(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_blockdem")).args(args).output().expect("runs");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn temp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("blockdem-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_deck(dir: &std::path::Path, text: &str) -> String {
    let p = dir.join("deck.dat");
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn sample_1_runs_and_writes_plots_and_state() {
    let dir = temp("sample1");
    let deck = format!("{}/examples/udec1_point_load_cracking.dat", env!("CARGO_MANIFEST_DIR"));
    let json = dir.join("state.json");
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap(), "--state-json", json.to_str().unwrap()]);
    assert_eq!(code, 0, "stderr: {stderr}");
    assert!(stdout.contains(")START"));
    assert!(stdout.contains("BLOCK DATA"));
    assert!(dir.join("plot_001.png").exists() && dir.join("plot_002.svg").exists());
    let state: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(state["dim"], 2);
    assert_eq!(state["cycle"], 600);
    assert_eq!(state["blocks"].as_array().unwrap().len(), 5);
}

#[test]
fn an_unknown_command_names_file_and_line_and_exits_nonzero() {
    let dir = temp("unknown");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nFROBNICATE 1 2\nSTOP\n");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("{deck}:3")), "{stderr}");
    assert!(stderr.to_lowercase().contains("frobnicate"), "{stderr}");
}

#[test]
fn a_scene_with_fluid_saves_and_restarts() {
    let dir = temp("fluidsave");
    // Fluid runs since issue 30, and its SAVE since save format 6.
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 CPERM=1E-9\nBLOCK 0,0 0,1 1,1 1,0\nFLUID 1000 2E9\nCYCLE 10\nSAVE\n");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let again = write_deck(&dir, "RESTART\nCYCLE 10\nSTOP\n");
    let state = dir.join("state.json");
    let (code, _, stderr) = blockdem(&["run", &again, "--backend", "cpu", "--out", dir.to_str().unwrap(), "--state-json", state.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&state).unwrap()).unwrap();
    assert_eq!(json["cycle"], 20);
    assert!(json["domains"].as_array().is_some_and(|d| !d.is_empty()) && json["fluid"]["bulk"] == 2e9, "{json}");
}

#[test]
fn cycle_with_no_blocks_is_an_error_with_its_line() {
    let dir = temp("noblocks");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nCYCLE 10\n");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("{deck}:3")) && stderr.contains("no blocks"), "{stderr}");
}

#[test]
fn a_self_intersecting_block_is_an_error_with_its_line() {
    let dir = temp("bowtie");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 1,1 1,0 0,1\n");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("{deck}:3")) && stderr.contains("crosses or touches itself"), "{stderr}");
}

/// The run log is buffered between BLOCK commands: after an error it still holds the echo of
/// every command up to the bad one, in order, and nothing after it.
#[test]
fn the_log_of_a_long_deck_is_whole_up_to_its_error() {
    let dir = temp("long-log");
    let mut text = String::from("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\n");
    for k in 0..3000 {
        text += &format!("BLOCK {k},0 {k},1 {},1 {},0\n", k + 1, k + 1);
    }
    text += "BLOCK 0,0 1,1 1,0 0,1\nBLOCK 5000,0 5000,1 5001,1 5001,0\nCYCLE 1\n";
    let deck = write_deck(&dir, &text);
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("{deck}:3003")), "{stderr}");
    let echoes: Vec<&str> = stdout.lines().filter(|l| l.starts_with(")BLOCK")).collect();
    assert_eq!(echoes.len(), 3001);
    assert_eq!(echoes[1234], ")BLOCK 1234,0 1234,1 1235,1 1235,0");
    assert_eq!(stdout.lines().last(), Some(")BLOCK 0,0 1,1 1,0 0,1"));
}

#[test]
fn an_overlap_beyond_half_the_rounding_stops_and_keeps_the_last_good_state() {
    // A block fired at 2 m/s into a fixed one 5 cm away: the soft contact (stopping distance
    // v√(m/kn) ≈ 0.09 m) cannot stop it within d/2 = 0.05 m.
    let dir = temp("overlap");
    let deck = write_deck(
        &dir,
        "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 1.05,0 1.05,1 2.05,1 2.05,0\nFIX 1 3 0 1\n\
         VELOCITY 0 1 0 1 2 0\nCYCLE 2000\n",
    );
    let json = dir.join("state.json");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap(), "--state-json", json.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("contact overlap too great") && (stderr.contains("blocks 1 and 2") || stderr.contains("blocks 2 and 1")), "{stderr}");
    assert!(dir.join("last_good.sav").exists(), "the last good state is saved");
    let state: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for b in state["blocks"].as_array().unwrap() {
        assert!(b["centroid"][0].as_f64().unwrap().is_finite());
    }
}

/// A misspelt `verify --only` case is an error naming the cases, not a run of nothing that passes.
#[test]
fn verify_only_a_case_that_does_not_exist_is_an_error() {
    let dir = temp("verify-only");
    let (code, _, stderr) = blockdem(&["verify", "--quick", "--only", "no_such_case", "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("--only no_such_case") && stderr.contains("free_flight"), "{stderr}");
}

/// A negative or zero number given to an option is refused with what the option expects (clap
/// took '-1' for an unknown option: "unexpected argument '-1' found").
#[test]
fn negative_option_values_are_refused_saying_what_is_expected() {
    for (args, want) in [
        (&["bench", "--frac", "-1"][..], "invalid value '-1' for '--frac <FRAC>': expected a number above zero"),
        (&["bench", "--settle-time", "-0.5"][..], "expected a number above zero, found '-0.5'"),
        (&["bench", "--measure", "0"][..], "expected a number above zero, found '0'"),
        (&["bench", "--max-blocks", "-2"][..], "expected a whole number above zero, found '-2'"),
        (&["bench", "--sizes", "1000,-3"][..], "expected a whole number above zero, found '-3'"),
        (&["run", "deck.dat", "--checkpoint-every", "-5"][..], "expected a number of seconds (0 or more), found '-5'"),
        (&["run", "deck.dat", "--vtk-every", "-3"][..], "expected a whole number above zero, found '-3'"),
        (&["compare", "deck.dat", "--tolerance", "-1"][..], "--tolerance must be a number, zero or more"),
    ] {
        let (code, _, stderr) = blockdem(args);
        assert_ne!(code, 0, "{args:?}");
        assert!(stderr.contains(want), "{args:?}: {stderr}");
    }
}

/// An output folder that cannot be one (a file, or under a file) is refused before any cycle runs,
/// by `run`, `bench` and `verify` alike, and nothing is written.
#[test]
fn an_out_folder_that_is_a_file_is_refused_before_the_run() {
    let dir = temp("out-file");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 2\nSAVE\n");
    let file = dir.join("afile");
    std::fs::write(&file, "").unwrap();
    let file = file.to_str().unwrap();
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", file]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("--out {file}: {file} is a file, not a folder")), "{stderr}");
    assert!(!stdout.contains("CYCLE"), "nothing runs: {stdout}");
    let under = format!("{file}/sub");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", &under]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("--out {under}: {file} is a file, not a folder")), "{stderr}");
    for args in [&["verify", "--quick", "--out", file][..], &["bench", "--quick", "--backend", "cpu", "--out", file][..]] {
        let (code, _, stderr) = blockdem(args);
        assert_ne!(code, 0, "{args:?}");
        assert!(stderr.contains("is a file, not a folder"), "{args:?}: {stderr}");
    }
    // A folder not there yet is made, with its parents, when the run writes to it.
    let fresh = dir.join("new/sub");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", fresh.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(fresh.join("blockdem.sav").exists());
    assert!(std::fs::read_dir(&dir).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().contains("write-test")), "the probe is removed");
    // --state-json likewise: a folder, or a file under a file, is refused before the run; a
    // folder not there yet is made.
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", out, "--state-json", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("--state-json") && stderr.contains("is a folder; give a file name"), "{stderr}");
    assert!(!stdout.contains("CYCLE"), "nothing runs: {stdout}");
    let under = format!("{file}/state.json");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", out, "--state-json", &under]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("--state-json {under}: {file} is a file, not a folder")), "{stderr}");
    let json = dir.join("new/json/state.json");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", out, "--state-json", json.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(json.exists());
}

/// An input error after cycles have run keeps them: the state before the failing command goes to
/// `last_good.sav`, and a RESTART of it goes on.
#[test]
fn an_input_error_after_cycles_keeps_the_state_before_it() {
    let dir = temp("late-error");
    let deck = write_deck(
        &dir,
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nGRAV 0 -10\nROUND 0.05\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\n\
         FIX 0 1 0 1\nCYCLE 300\nPROP MAT=25 D=1\nSTOP\n",
    );
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains(&format!("{deck}:9")), "{stderr}");
    assert!(stderr.contains("the state before the failing command (cycle 300)"), "{stderr}");
    let saved = blockdem::udec::output::load(&dir.join("last_good.sav")).unwrap();
    assert_eq!(saved.model.cycle, 300);
    let again = write_deck(&dir, &format!("RESTART {}\nCYCLE 100\nSTOP\n", dir.join("last_good.sav").display()));
    let (code, stdout, stderr) = blockdem(&["run", &again, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("CURRENT CYCLE COUNT = 400"), "{stdout}");
}

#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_long_cycle_at_an_energy_check_and_saves_its_state() {
    interrupt_a_long_cycle("-INT");
}

#[cfg(unix)]
#[test]
fn sigterm_stops_a_long_cycle_as_ctrl_c_does() {
    interrupt_a_long_cycle("-TERM");
}

#[cfg(unix)]
#[test]
fn sighup_under_nohup_leaves_the_run_going() {
    // blockdem handles SIGINT and SIGTERM only: a run started with `nohup` ignores the hang-up
    // of a closed terminal and goes on (it would stop within 100 cycles if it were caught).
    let dir = temp("nohup");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 100000000\nSTOP\n");
    let mut nohup = Command::new("nohup");
    nohup.args([env!("CARGO_BIN_EXE_blockdem"), "run", &deck, "--backend", "cpu", "--out", dir.join("out").to_str().unwrap()]);
    let (mut child, _stdout) = start_cycling(nohup);
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-HUP", &pid]).status().unwrap().success());
    std::thread::sleep(std::time::Duration::from_millis(500));
    let after_hangup = child.try_wait().unwrap();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let output = child.wait_with_output().unwrap();
    assert!(after_hangup.is_none(), "the hang-up ended the run: {after_hangup:?}");
    assert_eq!(output.status.code(), Some(130), "{}", String::from_utf8_lossy(&output.stderr));
}

/// Starts a run with its output piped and waits until its cycles have started: the log is
/// flushed before they do, and its time step line says they have.
#[cfg(unix)]
fn start_cycling(mut command: Command) -> (std::process::Child, std::io::BufReader<std::process::ChildStdout>) {
    use std::io::BufRead;
    let mut child = command.stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped()).spawn().expect("runs");
    let mut stdout = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut log = String::new();
    while !log.contains("INITIAL TIMESTEP") {
        assert!(stdout.read_line(&mut log).unwrap() > 0, "the run ended before its cycles: {log}");
    }
    (child, stdout)
}

#[cfg(unix)]
fn interrupt_a_long_cycle(signal: &str) {
    // A projectile bouncing off a wall for 10^8 cycles (hours): the signal, sent once the cycles
    // have started, ends the run at its next energy check (a multiple of 100 cycles), with the
    // state at that cycle saved for RESTART, a message naming the deck's CYCLE line, and the
    // shell's status for an interrupt (130). A RESTART from the file goes on.
    let dir = temp(&format!("interrupt{signal}"));
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=8000 KN=1E9 KS=1E9\nROUND 0.1\nBLOCK 0,0 0,0.5 0.5,0.5 0.5,0\nBLOCK 3,-1 3,1.5 4,1.5 4,-1\nFIX 2.5 4.5 -1.5 2\nVELOCITY 0 0.5 0 0.5 20 0\nCYCLE 100000000\nSTOP\n");
    let out = dir.join("out");
    let mut run = Command::new(env!("CARGO_BIN_EXE_blockdem"));
    run.args(["run", &deck, "--backend", "cpu", "--out", out.to_str().unwrap()]);
    let (child, mut stdout) = start_cycling(run);
    std::thread::sleep(std::time::Duration::from_millis(300));
    let sent = Command::new("kill").args([signal, &child.id().to_string()]).status().expect("kill runs");
    assert!(sent.success());
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stdout, &mut rest).unwrap();
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "stderr: {stderr}");
    assert!(stderr.contains("deck.dat:8: interrupted at cycle"), "{stderr}");
    let saved = blockdem::udec::output::load(&out.join("last_good.sav")).unwrap();
    let cycle = saved.model.cycle;
    assert!(cycle > 0 && cycle % 100 == 0 && cycle < 100_000_000, "saved at cycle {cycle}");
    assert!(stderr.contains(&format!("the state (cycle {cycle}) is saved")), "{stderr}");
    assert!(rest.contains(&format!("CYCLE INTERRUPTED AFTER {cycle} OF 100000000 CYCLES")), "{rest}");
    let again = write_deck(&dir, &format!("RESTART {}\nCYCLE 100\nSTOP\n", out.join("last_good.sav").display()));
    let (code, stdout, stderr) = blockdem(&["run", &again, "--backend", "cpu", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains(&format!("CURRENT CYCLE COUNT = {}", cycle + 100)), "{stdout}");
}

#[test]
fn a_running_restart_file_is_written_with_checkpoint_every() {
    // --checkpoint-every 0: the file after every piece of the CYCLE, the last one the final state;
    // a RESTART from it goes on. A bad value is an argument error.
    let dir = temp("checkpoint");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nGRAVITY 0 -10\nCYCLE 450\nSTOP\n");
    let out = dir.join("out");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", out.to_str().unwrap(), "--checkpoint-every", "0"]);
    assert_eq!(code, 0, "{stderr}");
    let saved = blockdem::udec::output::load(&out.join("checkpoint.sav")).unwrap();
    assert_eq!(saved.model.cycle, 450);
    let again = write_deck(&dir, &format!("RESTART {}\nCYCLE 50\nSTOP\n", out.join("checkpoint.sav").display()));
    let (code, stdout, stderr) = blockdem(&["run", &again, "--backend", "cpu", "--out", out.to_str().unwrap()]);
    assert!(code == 0 && stdout.contains("CURRENT CYCLE COUNT = 500"), "{stdout}{stderr}");
    let (code, _, stderr) = blockdem(&["run", &deck, "--checkpoint-every", "soon"]);
    assert!(code != 0 && stderr.contains("expected a number of seconds"), "{stderr}");
}

#[test]
fn vtk_frames_are_written_by_the_vtk_command_and_with_vtk_every() {
    // --vtk-every 150 (rounded up to 200): frames at cycles 0, 200 and 400 of the CYCLE; the VTK
    // command adds one of the state at 450. Each frame is a blocks and a contacts file, listed
    // in the two series files. 0 cycles is an argument error.
    let dir = temp("vtk");
    let deck = write_deck(
        &dir,
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX 0 1 0 0.9\nGRAVITY 0 -10\nCYCLE 450\nVTK\nSTOP\n",
    );
    let out = dir.join("out");
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", out.to_str().unwrap(), "--vtk-every", "150"]);
    assert_eq!(code, 0, "{stderr}");
    let vtk = out.join("vtk");
    assert!(stdout.contains(&format!("VTK FRAME WRITTEN TO {}", vtk.join("blocks_000000450.vtk").display())), "{stdout}");
    for cycle in [0, 200, 400, 450] {
        for kind in ["blocks", "contacts"] {
            assert!(vtk.join(format!("{kind}_{cycle:09}.vtk")).is_file(), "{kind} frame of cycle {cycle}");
        }
    }
    let series: blockdem::udec::output::vtk::Series = serde_json::from_slice(&std::fs::read(vtk.join("contacts.vtk.series")).unwrap()).unwrap();
    assert_eq!(series.files.len(), 4);
    let (code, _, stderr) = blockdem(&["run", &deck, "--vtk-every", "0"]);
    assert!(code != 0 && stderr.contains("--vtk-every"), "{stderr}");
}

#[test]
fn an_unstable_fraction_is_caught_before_any_nan() {
    // FRAC 5 is far above the stable limit of the central-difference scheme (≈ 0.5 here).
    let dir = temp("unstable");
    let deck = write_deck(
        &dir,
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nFRAC 5\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 5000\n",
    );
    let json = dir.join("state.json");
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap(), "--state-json", json.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("FRACTION") || stderr.contains("overlap"), "{stderr}");
    let text = std::fs::read_to_string(&json).unwrap();
    assert!(!text.contains("NaN") && !text.contains("null"), "the saved state holds no NaN");
}

#[test]
fn a_projectile_that_would_tunnel_is_stopped_with_a_message() {
    // 200 m/s with Δt ≈ 9e-3 s: 1.8 m a step, through a 1 m block in one step.
    let dir = temp("tunnel");
    let deck = write_deck(
        &dir,
        "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 3,0 3,1 4,1 4,0\nFIX 2 5 0 1\n\
         VELOCITY 0 1 0 1 200 0\nCYCLE 100\n",
    );
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("moves too fast") && stderr.contains("block 1"), "{stderr}");
}

#[test]
fn an_empty_or_binary_deck_is_an_error_not_a_panic() {
    let dir = temp("binary");
    let empty = write_deck(&dir, "* only a comment\n\n");
    let (code, _, stderr) = blockdem(&["run", &empty, "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("empty deck") && !stderr.contains("panicked"), "{stderr}");
    let bin = dir.join("bin.dat");
    std::fs::write(&bin, [b'S', b'T', 0u8, 0xff, 0xfe, b'\n']).unwrap();
    let (code, _, stderr) = blockdem(&["run", bin.to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("binary file") && !stderr.contains("panicked"), "{stderr}");
    let (code, _, stderr) = blockdem(&["run", dir.join("missing.dat").to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("cannot read"), "{stderr}");
}

/// A deck of NUL bytes is refused at its first bytes, with its line; so is a FIFO fed NULs for
/// ever (read whole, it would never end and would fill the memory), and RESTART from a FIFO fed
/// NULs is refused at its header.
#[test]
fn an_input_of_nul_bytes_is_refused_at_its_start_even_without_an_end() {
    let dir = temp("nul");
    let zeros = dir.join("zeros.dat");
    std::fs::write(&zeros, vec![0u8; 1 << 20]).unwrap();
    let (code, _, stderr) = blockdem(&["run", zeros.to_str().unwrap(), "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(stderr.contains(&format!("{}:1:1: binary file: a NUL byte at line 1", zeros.display())), "{stderr}");
    #[cfg(unix)]
    {
        let fifo = dir.join("endless");
        assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        // NULs written until the reader goes (the write then fails: Rust ignores SIGPIPE). A
        // writer left waiting for a reader that never came is a detached thread, ended with the
        // test.
        let feed = |fifo: std::path::PathBuf| {
            std::thread::spawn(move || {
                use std::io::Write;
                let mut w = std::fs::OpenOptions::new().write(true).open(fifo).unwrap();
                let zeros = vec![0u8; 1 << 16];
                while w.write_all(&zeros).is_ok() {}
            })
        };
        feed(fifo.clone());
        let start = std::time::Instant::now();
        let (code, _, stderr) = blockdem(&["run", fifo.to_str().unwrap(), "--backend", "cpu", "--out", dir.to_str().unwrap()]);
        assert_eq!(code, 1);
        assert!(stderr.contains("binary file: a NUL byte at line 1"), "{stderr}");
        assert!(start.elapsed().as_secs() < 20, "read on for {:?}", start.elapsed());
        feed(fifo.clone());
        let deck = write_deck(&dir, &format!("RESTART {}\n", fifo.display()));
        let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
        assert_eq!(code, 1);
        assert!(stderr.contains(&format!("{deck}:1: RESTART: {} is not a blockdem save file", fifo.display())), "{stderr}");
    }
}

#[test]
fn verify_quick_passes_and_writes_csv_and_charts() {
    // The binary's side of verify (its options, its table, its files) on one cheap case: the
    // whole quick suite, stability table included, is tests/suite/verify.rs's (it takes minutes).
    let dir = temp("verify");
    let (code, stdout, stderr) = blockdem(&["verify", "--quick", "--only", "free_flight", "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    assert!(stdout.contains("CLOSED-FORM CHECKS") && stdout.contains("free_flight") && !stdout.contains("griffith"), "{stdout}");
    for f in ["sweep.csv", "stability.csv", "extremes.csv"] {
        assert!(dir.join(f).exists(), "{f} missing");
    }
    // The charts need DejaVu Sans; where it is installed they must be drawn.
    if std::path::Path::new("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").exists() {
        assert!(dir.join("accuracy_vs_speed.png").exists() && dir.join("error_vs_frac.png").exists(), "{stderr}");
    }
}

/// Every bad-input case of issue 2 item 7, through the binary: a non-zero exit, an error that names
/// the file and the line (and what was expected), never a panic.
#[test]
fn every_bad_input_names_file_line_and_what_was_expected() {
    let dir = temp("badinput");
    let ok = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\n";
    let cases: Vec<(&str, Vec<u8>, usize, &str)> = vec![
        ("empty", b"".to_vec(), 1, "empty deck"),
        ("only comments", b"* nothing\n\n".to_vec(), 1, "expected START or RESTART"),
        ("binary", vec![b'S', b'T', 0, 1, 2, 0xff, b'\n'], 1, "binary file"),
        ("not utf-8", b"START\nGRAV 0 \xff\xfe\n".to_vec(), 2, "binary file"),
        ("long line", format!("START\nGRAV 0 -10 {}\n", "1".repeat(10_000)).into_bytes(), 2, "line too long"),
        ("unknown command", format!("{ok}FROB 1\n").into_bytes(), 3, "unknown command 'FROB'; expected one of"),
        ("unknown keyword", format!("{ok}PROP MAT=1 XX=2\n").into_bytes(), 3, "expected a property keyword"),
        ("missing value", format!("{ok}GRAV 0\n").into_bytes(), 3, "GRAVITY needs 2 numbers"),
        ("non-numeric", format!("{ok}GRAV 0 abc\n").into_bytes(), 3, "expected a number for gy, found 'abc'"),
        ("NaN", format!("{ok}GRAV 0 NaN\n").into_bytes(), 3, "expected a finite number for gy"),
        ("overflow", format!("{ok}GRAV 0 1E400\n").into_bytes(), 3, "out of range"),
        ("zero density", format!("{ok}PROP MAT=1 D=0\n").into_bytes(), 3, "density must be positive, found 0"),
        ("negative stiffness", format!("{ok}PROP MAT=1 KS=-1E8\n").into_bytes(), 3, "ks must be positive"),
        ("two corners", format!("{ok}BLOCK 0,0 1,1\n").into_bytes(), 3, "BLOCK needs at least 3 corners"),
        ("self-intersecting", format!("{ok}BLOCK 0,0 1,1 1,0 0,1\n").into_bytes(), 3, "crosses or touches itself"),
        ("first not START", b"BLOCK 0,0 0,1 1,1\n".to_vec(), 1, "the first command must be START or RESTART"),
        ("cycle with no blocks", format!("{ok}CYCLE 10\n").into_bytes(), 3, "there are no blocks"),
        ("negative cycles", format!("{ok}BLOCK 0,0 0,1 1,1 1,0\nCYCLE -10\n").into_bytes(), 4, "a negative cycle count is not allowed"),
        ("dangling continuation", b"+ 1 2\nSTART\n".to_vec(), 1, "continuation line ('+') with no command before it"),
    ];
    for (what, bytes, line, needle) in cases {
        let p = dir.join(format!("{}.dat", what.replace(' ', "_")));
        std::fs::write(&p, &bytes).unwrap();
        let deck = p.display().to_string();
        let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
        assert_eq!(code, 1, "{what}: exit status\n{stderr}");
        assert!(!stderr.contains("panicked"), "{what}: {stderr}");
        assert!(stderr.starts_with(&format!("error: {deck}:{line}:")), "{what}: file and line {line}: {stderr}");
        assert!(stderr.contains(needle), "{what}: expected '{needle}': {stderr}");
    }
}

#[test]
fn every_sample_deck_runs_unchanged() {
    // Samples 1 to 4 run to their end (2 since fluid came, issue 30; 4 prints DLIST, the
    // domains); the D3 deck runs on the D3 engine to its end (its tables: tests/suite/d3_deck.rs).
    let dir = temp("samples");
    for name in
        ["udec1_point_load_cracking.dat", "udec2_pressurized_cavity.dat", "udec3_deformable_block.dat", "udec4_projectile_beam.dat", "d3_two_tetrahedra.dat"]
    {
        let deck = format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"));
        let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(code == 0 && (stdout.contains(")STOP") || stdout.contains(">STOP")), "{name}: {stderr}");
    }
}

#[test]
fn long_cycles_show_a_bar_on_a_terminal_and_progress_lines_otherwise() {
    // 2e6 cycles of one free block (~0.5 s): long enough for the bar to draw. Through a pipe (as
    // here) there is none; under a pseudo-terminal (util-linux `script`, in Debian's essential
    // bsdutils) there is one.
    let dir = temp("progress");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 2000000\n");
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!stdout.contains("/2000000 cycles") && !stderr.contains("/2000000 cycles"), "a bar on a pipe:\n{stdout}{stderr}");
    // Through a pipe a long run says how far it is on stderr instead, every 30 s (none in this
    // short run) or every BLOCKDEM_PROGRESS_SECONDS; the log on stdout is untouched.
    assert!(!stderr.contains("blockdem: cycle "), "{stderr}");
    let out = Command::new(env!("CARGO_BIN_EXE_blockdem"))
        .args(["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap()])
        .env("BLOCKDEM_PROGRESS_SECONDS", "0.005")
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success() && !stdout.contains("blockdem: cycle "), "{stderr}");
    let done: Vec<u64> = stderr
        .lines()
        .filter_map(|l| l.strip_prefix("blockdem: cycle "))
        .map(|l| {
            assert!(l.contains(" of 2000000 (") && l.contains(" cycles/s, about ") && l.ends_with(" s left"), "{l}");
            l.split(' ').next().unwrap().parse().unwrap()
        })
        .collect();
    assert!(done.len() >= 2 && done.windows(2).all(|w| w[0] < w[1]) && done.iter().all(|&d| d % 100 == 0 && d < 2_000_000), "{stderr}");
    if !std::path::Path::new("/usr/bin/script").exists() {
        eprintln!("skipped the terminal half: no /usr/bin/script");
        return;
    }
    let line = format!("{} run {deck} --backend cpu --out {}", env!("CARGO_BIN_EXE_blockdem"), dir.display());
    let out = Command::new("/usr/bin/script").args(["-qec", &line, "/dev/null"]).output().expect("script runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("/2000000 cycles"), "no progress bar on a terminal:\n{text}");
    // Its rate reads as a number of cycles per second (it showed "6,531.7848/s").
    let rate = text.split(" cycles/s").next().and_then(|t| t.split_whitespace().last()).unwrap_or_default();
    assert!(text.contains(" cycles/s") && rate.parse::<f64>().is_ok() && !rate.contains(','), "rate '{rate}':\n{text}");
    assert!(text.contains("CURRENT CYCLE COUNT = 2000000"), "{text}");
}

/// `--state-json` to a FIFO writes through it (a reader gets the JSON) and leaves it a FIFO;
/// to a symbolic link, it writes the file the link names and leaves the link.
#[cfg(unix)]
#[test]
fn the_state_file_writes_through_a_fifo_and_a_symbolic_link() {
    use std::os::unix::fs::FileTypeExt;
    let dir = temp("state_fifo");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nGRAVITY 0 -10\nCYCLE 10\nSTOP\n");
    let (fifo, came) = (dir.join("pipe"), dir.join("came_through.json"));
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    // `cat` reads the FIFO, so that neither side waits for ever on the other; killed if it is
    // still waiting once the run is over.
    let mut cat = Command::new("cat").arg(&fifo).stdout(std::fs::File::create(&came).unwrap()).spawn().unwrap();
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap(), "--state-json", fifo.to_str().unwrap()]);
    let start = std::time::Instant::now();
    while cat.try_wait().unwrap().is_none() && start.elapsed().as_secs() < 20 {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let _ = cat.kill();
    let _ = cat.wait();
    assert_eq!(code, 0, "{stderr}");
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the FIFO was replaced by a file");
    let state: serde_json::Value = serde_json::from_slice(&std::fs::read(&came).unwrap()).unwrap();
    assert_eq!(state["cycle"], 10);

    let link = dir.join("latest.json");
    std::os::unix::fs::symlink("came_through.json", &link).unwrap();
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap(), "--state-json", link.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link was replaced");
    let again: serde_json::Value = serde_json::from_slice(&std::fs::read(&came).unwrap()).unwrap();
    assert_eq!(again, state);
}

/// Runs blockdem with its standard output a pipe whose reader has gone before the first write
/// (`blockdem … | true`); returns the exit status and stderr.
fn with_stdout_closed(args: &[&str]) -> (i32, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_blockdem"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("runs");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("ends");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into())
}

/// Issue 27 item 2: no subcommand panics when its reader leaves (`| head`, `| true`); the work
/// goes on and writes its files, and the exit status is the work's own.
#[test]
fn no_subcommand_panics_when_stdout_is_closed() {
    let dir = temp("closed-stdout");
    let out = |name: &str| dir.join(name).display().to_string();
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBLOCK 0,0 0,1 1,1 1,0\nGRAV 0 -10\nCYCLE 10\nPRINT BLOCKS\nEND\n");
    let json = out("state.json");
    let runs: Vec<Vec<String>> = vec![
        vec!["adapters".into()],
        vec!["run".into(), deck.clone(), "--backend".into(), "cpu".into(), "--out".into(), out("run"), "--state-json".into(), json.clone()],
        vec!["verify".into(), "--quick".into(), "--only".into(), "free_flight".into(), "--out".into(), out("verify")],
        vec!["compare".into(), deck.clone(), "--out".into(), out("compare")],
        vec![
            "bench".into(),
            "--quick".into(),
            "--scene".into(),
            "scaling".into(),
            "--backend".into(),
            "cpu".into(),
            "--sizes".into(),
            "1000".into(),
            "--measure".into(),
            "0.05".into(),
            "--rounds".into(),
            "1".into(),
            "--out".into(),
            out("bench"),
        ],
    ];
    for args in runs {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, stderr) = with_stdout_closed(&args);
        assert!(!stderr.contains("panicked") && code != 101, "{args:?}: exit {code}\n{stderr}");
        // `compare` needs a GPU adapter; without one it fails as it would with stdout open.
        if args[0] != "compare" {
            assert_eq!(code, 0, "{args:?}:\n{stderr}");
        }
    }
    // The work went on after its reader left: the run's state and verify's tables are written.
    assert!(std::path::Path::new(&json).exists() && dir.join("verify").join("sweep.csv").exists());
    // A log that cannot be written (a full disk) is an error, not lost in silence.
    if std::path::Path::new("/dev/full").exists() {
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_blockdem")).args(["run", &deck, "--backend", "cpu", "--out", &out("full")]).stdout(full).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("cannot write to standard output") && !stderr.contains("panicked"), "{stderr}");
    }
}

/// Issue 27 item 8: the log says what made it — a provenance line under the banner (version,
/// commit, deck, backend, adapter, precision, date UTC) — and the state JSON holds the same under
/// `provenance`, its other keys kept.
#[test]
fn the_log_and_the_state_json_name_what_made_them() {
    let dir = temp("provenance");
    let deck = write_deck(&dir, "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 1\n");
    let json = dir.join("state.json");
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", dir.to_str().unwrap(), "--state-json", json.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let lines: Vec<&str> = stdout.lines().collect();
    let banner = lines.iter().position(|l| l.starts_with("PROGRAM UDEC")).expect("banner");
    let line = lines[banner + 1];
    let version = env!("CARGO_PKG_VERSION");
    assert!(line.starts_with(&format!("BLOCKDEM {version} (COMMIT ")), "{line}");
    assert!(line.contains(&format!("  DECK {deck}  BACKEND cpu  ADAPTER none  PRECISION f64  DATE ")), "{line}");
    let date = line.rsplit(' ').next().unwrap();
    assert!(date.len() == 20 && date.starts_with("20") && date.ends_with('Z') && date.as_bytes()[10] == b'T', "{date}");
    let state: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let p = &state["provenance"];
    assert_eq!(p["version"], version);
    assert_eq!(p["deck"], deck.as_str());
    assert_eq!(p["backend"], "cpu");
    assert_eq!(p["adapter"], "none");
    assert_eq!(p["precision"], "f64");
    assert_eq!(p["date"], date);
    assert!(p["commit"].is_string());
    for key in ["blocks", "contacts", "cycle", "dim", "energy", "gravity", "time", "timestep"] {
        assert!(state.get(key).is_some(), "{key} missing");
    }
}

/// Issue 27 item 9: `--adapter` or `--precision` with `--backend cpu` is said to be ignored (it
/// was accepted without a word), and so is text after END, naming its line.
#[test]
fn ignored_options_and_text_after_end_are_said_to_be_ignored() {
    let dir = temp("ignored");
    let out = dir.join("out");
    let body = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 1\nEND\n";
    let deck = write_deck(&dir, &format!("{body}\n* a comment\n  ,\nCYCLE 100\n"));
    let (code, stdout, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--adapter", "gl", "--precision", "f64", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("blockdem: --backend cpu runs in f64 on the CPU; --adapter and --precision ignored"), "{stderr}");
    assert!(stderr.contains(&format!("blockdem: {deck}:9: text after END is ignored")), "{stderr}");
    assert!(!stdout.contains("CYCLE 100"), "{stdout}");
    let (_, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--precision", "f32", "--out", out.to_str().unwrap()]);
    assert!(stderr.contains("; --precision ignored"), "{stderr}");
    // Neither is said without cause.
    let deck = write_deck(&dir, &format!("{body}\n* only a comment after END\n"));
    let (code, _, stderr) = blockdem(&["run", &deck, "--backend", "cpu", "--out", out.to_str().unwrap()]);
    assert!(code == 0 && !stderr.contains("ignored"), "{stderr}");
}

/// `bench --scene` takes several scenes separated by commas, and the SDEF wall brings the dry
/// settle it is measured against (so its TARGETS row is there when asked for alone); an unknown
/// scene is refused with the list of those that exist.
#[test]
fn bench_scenes_combine_and_sdef_brings_its_dry_wall() {
    let dir = temp("bench-scenes");
    let out = dir.join("out");
    // A short bench on the CPU of `scenes` into `out`, with the further `args`.
    let quick = |scenes: &str, args: &[&str], out: &std::path::Path| {
        let mut all = vec!["bench", "--quick", "--backend", "cpu", "--scene", scenes, "--settle-time", "0.02", "--out", out.to_str().unwrap()];
        all.extend_from_slice(args);
        blockdem(&all)
    };
    let (code, stdout, stderr) = quick("sdef,impact", &["--impact-time", "0.02"], &out);
    assert_eq!(code, 0, "{stderr}");
    let rows: Vec<&str> =
        stdout.lines().filter(|l| l.ends_with(|c: char| c.is_ascii_digit()) && l.contains("cpu f64")).map(|l| l.split_whitespace().next().unwrap()).collect();
    for scene in ["settle", "impact", "sdef"] {
        assert!(rows.contains(&scene), "no {scene} row in {stdout}");
    }
    assert!(stdout.lines().any(|l| l.starts_with("SDEF wall vs rigid wall") && l.contains("cpu f64")), "{stdout}");
    // --sizes goes to the D3 wall when no scaling family is asked for, whatever else is.
    let out = dir.join("d3");
    let (code, _, stderr) = quick("d3-wall,settle", &["--sizes", "20"], &out);
    assert_eq!(code, 0, "{stderr}");
    let csv = std::fs::read_to_string(out.join("bench_d3.csv")).unwrap();
    assert!(csv.lines().skip(1).all(|l| l.starts_with("d3-wall") && l.split(',').any(|f| f == "21")) && csv.lines().count() == 2, "{csv}");
    let (code, _, stderr) = blockdem(&["bench", "--scene", "sdef,bogus"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("invalid value 'bogus'") && stderr.contains("sdef-scaling"), "{stderr}");
}
