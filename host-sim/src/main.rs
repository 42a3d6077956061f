//! `host-sim`: see `host-sim --help`. The command line only: the domain is
//! `fracbms-host`'s.

mod cli;

fn main() {
    std::process::exit(cli::main());
}
