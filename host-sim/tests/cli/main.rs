//! End-to-end: run the host-sim binary on files, one module per kind of
//! command, and bad data apart.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod bad_data;
mod battery;
mod cycler;
mod hammerstein;
mod life;
mod many;
mod map;
mod ocv;
mod persistence;
mod predict;
mod real;
mod slow_part;
mod state_of_power;
mod tracking;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fracbms-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// Asserts that `o` is a refused command: exit 1 and one line on stderr
/// holding each of `expect` (`what` names the case in a failure).
fn assert_one_line_error(o: &Output, expect: &[&str], what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{what}: {err}");
    assert!(
        expect.iter().all(|e| err.contains(e)) && err.trim().lines().count() == 1,
        "{what}: {err}"
    );
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A file under the repository's `data/`.
fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data")
        .join(name)
}

fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}
