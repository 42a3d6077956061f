//! The host-sim command line, built inside this package so that the
//! end-to-end tests can run it through `CARGO_BIN_EXE_host-sim-e2e`.
fn main() {
    std::process::exit(host_sim::cli::main());
}
