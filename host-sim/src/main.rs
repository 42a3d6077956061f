//! `host-sim`: see `host-sim --help`.
fn main() {
    std::process::exit(host_sim::cli::main());
}
