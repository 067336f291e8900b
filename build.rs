//! Stamps the binary with the commit it was built from (`blockdem bench` reports it): a bench run
//! on a copy of the tree (a lent GPU machine) then names the commit that was built, not whatever
//! `git` finds where it runs. Reruns when HEAD moves; a tree without git gets no stamp.

use std::path::Path;
use std::process::Command;

fn main() {
    let git = Path::new(".git");
    if git.is_dir() {
        println!("cargo:rerun-if-changed=.git/HEAD");
        if let Ok(head) = std::fs::read_to_string(git.join("HEAD")) {
            if let Some(reference) = head.strip_prefix("ref: ") {
                println!("cargo:rerun-if-changed=.git/{}", reference.trim());
            }
        }
        // Only when it exists: cargo counts a missing watched file as changed, and would rebuild
        // the crate on every invocation in a repository without packed refs.
        if git.join("packed-refs").is_file() {
            println!("cargo:rerun-if-changed=.git/packed-refs");
        }
    }
    let commit = Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    if let Some(c) = commit.filter(|c| !c.is_empty()) {
        println!("cargo:rustc-env=BLOCKDEM_COMMIT={c}");
    }
}
