//! The fracbms firmware: one cell's estimator on a Cortex-M4F.
//!
//! Build for the target (`thumbv7em-none-eabihf`); the board is a cargo
//! feature (`board-qemu`, the default, or `board-stm32l452`). On the host
//! this binary only explains how to run it.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;
#[cfg(target_os = "none")]
mod persist;
#[cfg(target_os = "none")]
mod run;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "the firmware runs on thumbv7em-none-eabihf: `cargo xtask qemu --input FILE.csv` \
         runs it under QEMU (see README.md)"
    );
    std::process::exit(2);
}
