//! `blockdem`: run UDEC 1.2 command decks.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::{Parser, Subcommand, ValueEnum};

use blockdem::cpu::CpuBackend;
use blockdem::exec::{Executor, RunOptions};

#[derive(Parser)]
#[command(name = "blockdem", version, about = "Distinct element code for jointed rock (UDEC 1.2 / D3 after Cundall & Hart 1985)")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum BackendChoice {
    /// A GPU adapter when there is one, otherwise the CPU.
    Auto,
    /// The f64 CPU backend (the accuracy reference).
    Cpu,
    /// The wgpu backend (not built yet).
    Gpu,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a command deck (START … STOP/END).
    Run {
        /// The deck file.
        deck: PathBuf,
        #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
        backend: BackendChoice,
        /// Folder for PLOT files and unnamed SAVE files.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Write the final state as JSON (also after a numerical failure: the last good state).
        #[arg(long)]
        state_json: Option<PathBuf>,
    },
    /// Run the closed-form verification suite on every backend: a table of errors and costs, CSV
    /// files and charts in --out. Exits non-zero when a check fails.
    Verify {
        /// The CI suite (fewer FRACTIONs, shorter stability bisections; well under 3 minutes).
        #[arg(long)]
        quick: bool,
        /// Folder for the CSV files and PNG charts.
        #[arg(long, default_value = "verify-out")]
        out: PathBuf,
        /// Run only the cases whose name contains this.
        #[arg(long)]
        only: Option<String>,
    },
}

fn verify(quick: bool, out: PathBuf, only: Option<String>) -> anyhow::Result<()> {
    let options = blockdem::verify::VerifyOptions { quick, out: Some(out.clone()), only };
    let suite = blockdem::verify::run_suite(&options);
    print!("{}", blockdem::verify::table(&suite));
    let (files, chart_problem) = blockdem::verify::write_outputs(&suite, &out).with_context(|| format!("cannot write into {}", out.display()))?;
    for f in files {
        println!("wrote {}", f.display());
    }
    if let Some(p) = chart_problem {
        eprintln!("blockdem: charts not drawn: {p}");
    }
    let failed: Vec<String> = suite.failed_checks().iter().map(|r| format!("{} ({} {})", r.case, r.backend, r.precision)).collect();
    let unstable: Vec<&str> = suite.stability.iter().filter(|t| !t.passed).map(|t| t.scene).collect();
    if !failed.is_empty() || !unstable.is_empty() {
        bail!("verification failed: closed-form checks {:?}, stability estimates {:?}", failed, unstable);
    }
    Ok(())
}

fn run(deck: PathBuf, backend: BackendChoice, out: PathBuf, state_json: Option<PathBuf>) -> anyhow::Result<()> {
    let name = deck.display().to_string();
    let bytes = std::fs::read(&deck).with_context(|| format!("cannot read the deck {name}"))?;
    let commands = blockdem::deck::parse::parse_deck_bytes(&bytes, &name)?;
    let backend: Box<dyn blockdem::backend::Backend> = match backend {
        BackendChoice::Cpu => Box::new(CpuBackend::new()),
        BackendChoice::Auto => {
            eprintln!("blockdem: no GPU backend in this build yet; running on the CPU (f64)");
            Box::new(CpuBackend::new())
        }
        BackendChoice::Gpu => bail!("--backend gpu: the GPU backend is not built yet; use --backend cpu"),
    };
    let options = RunOptions { out_dir: out.clone(), progress: std::io::stdout().is_terminal() };
    let mut exec = Executor::new(backend, Box::new(std::io::stdout()), options, &name);
    let result = exec.run(&commands);
    if let Some(path) = &state_json {
        blockdem::output::state_json::write_state_json(&exec.model, path).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let Err(e) = result {
        if e.is_numerical() {
            // Never lose work: the last good state goes to a restart file beside the plots.
            let _ = std::fs::create_dir_all(&out);
            let path = out.join("last_good.sav");
            let save = blockdem::output::restart::SaveFile { model: exec.model.clone(), plot: Default::default(), plot_count: 0 };
            if blockdem::output::restart::save(&path, &save).is_ok() {
                eprintln!("blockdem: the last good state (cycle {}) is saved in {}", exec.model.cycle, path.display());
            }
        }
        return Err(e.into());
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Cmd::Run { deck, backend, out, state_json } => run(deck, backend, out, state_json),
        Cmd::Verify { quick, out, only } => verify(quick, out, only),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
