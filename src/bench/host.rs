//! The machine the bench runs on: CPU model and cores, memory, the host's copy bandwidth, and the
//! byte model of the CPU backend's cycle.

use rayon::prelude::*;
use std::time::Instant;

use crate::udec::gpu::profile::StageBytes;

/// What the table header and the JSON say about the machine.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct MachineInfo {
    pub cpu_model: String,
    /// Logical cores (`std::thread::available_parallelism`).
    pub cores: usize,
    /// Threads of rayon's pool, which the CPU backend uses.
    pub rayon_threads: usize,
    pub memory_total_bytes: u64,
    pub os: String,
    /// UTC date of the run (YYYY-MM-DD).
    pub date: String,
    /// The commit the binary was built from (`git rev-parse --short HEAD` at build time).
    pub commit: Option<String>,
}

fn meminfo(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Memory the system could give this process now (MemAvailable), if known.
pub fn memory_available() -> Option<u64> {
    meminfo("MemAvailable:")
}

pub fn machine_info() -> MachineInfo {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu_model = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let os = std::fs::read_to_string("/etc/os-release")
        .ok()
        .and_then(|t| t.lines().find(|l| l.starts_with("PRETTY_NAME=")).map(|l| l["PRETTY_NAME=".len()..].trim_matches('"').to_string()))
        .unwrap_or_else(|| std::env::consts::OS.to_string());
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let (y, m, d) = crate::output::provenance::civil_from_days((secs / 86_400) as i64);
    // The commit the binary was built from (build.rs), else what git says where it was built.
    let commit = option_env!("BLOCKDEM_COMMIT").map(str::to_string).or_else(|| {
        std::process::Command::new("git")
            .args(["rev-parse", "--short", "HEAD"])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    });
    MachineInfo {
        cpu_model,
        cores: std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        rayon_threads: rayon::current_num_threads(),
        memory_total_bytes: meminfo("MemTotal:").unwrap_or(0),
        os,
        date: format!("{y:04}-{m:02}-{d:02}"),
        commit,
    }
}

/// The host's copy bandwidth, bytes read + written per second: a 128 MiB copy (far beyond the
/// caches) split over rayon's threads, as the CPU backend's stages are; the best of five.
pub fn host_copy_bandwidth() -> f64 {
    let words = (128usize << 20) / 8;
    let src = vec![1u64; words];
    let mut dst = vec![0u64; words];
    let chunk = words.div_ceil(rayon::current_num_threads().max(1) * 4);
    let mut best = 0.0f64;
    for _ in 0..5 {
        let start = Instant::now();
        dst.par_chunks_mut(chunk).zip(src.par_chunks(chunk)).for_each(|(d, s)| d.copy_from_slice(s));
        let t = start.elapsed().as_secs_f64();
        best = best.max(2.0 * (words * 8) as f64 / t.max(1e-9));
    }
    std::hint::black_box(&dst);
    best
}

/// The compulsory traffic of the CPU backend's cycle, counted as for the GPU kernels
/// (`gpu::profile`): every `Model` struct a stage reads counts once, every one it writes once.
/// The CPU structs are larger than the GPU's (f64, plus bookkeeping the cycle does not touch but
/// that shares its cache lines).
pub fn cpu_bytes_per_cycle(nb: usize, nc: usize, nk: usize) -> Vec<StageBytes> {
    use crate::udec::model::{Block, Contact, Corner};
    let (b, c, k) = (std::mem::size_of::<Block>() as u64, std::mem::size_of::<Corner>() as u64, std::mem::size_of::<Contact>() as u64);
    let (nb, nc, nk) = (nb as u64, nc as u64, nk as u64);
    vec![
        // The block pass: the gather's adjacency lists and the 32-byte copies of the contact
        // forces (cpu::gather::ContactForce), then the blocks and their corners. Stage 6 alone
        // ("gather alone (6)") runs only between cycles.
        StageBytes { stage: "gather+motion+geometry (6,1,2)", read: b * nb + c * nc + 4 * (nb + 1) + 8 * nk + 32 * nk, written: b * nb + c * nc },
        StageBytes { stage: "contact forces (4)", read: k * nk + c * nc + b * nb, written: k * nk + 32 * nk },
    ]
}
