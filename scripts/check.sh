#!/usr/bin/env bash
# The project's test command: formatting, lints, the no_std build for the
# Cortex-M4F target, then the host test suite (its summary is the last line).
set -euo pipefail
cd "$(dirname "$0")/.."

# rust-toolchain.toml pins the toolchain, the thumbv7em-none-eabihf target
# and the clippy/rustfmt/llvm-tools components; rustup installs them on first
# use. Make sure they are present even with an older rustup.
if command -v rustup >/dev/null 2>&1; then
  rustup show active-toolchain >/dev/null
  rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
  rustup component add clippy rustfmt llvm-tools >/dev/null 2>&1 || true
fi

echo "== cargo fmt --check"
cargo fmt --all --check
echo "== cargo clippy (host crates, all targets)"
cargo clippy --all-targets -- -D warnings
echo "== no_std build: estimator-core for thumbv7em-none-eabihf"
cargo build -p estimator-core --target thumbv7em-none-eabihf --release
cargo clippy -p estimator-core --target thumbv7em-none-eabihf -- -D warnings
echo "== cargo test"
cargo test --workspace --exclude firmware 2>&1 | tee target/test-output.txt
# Finish on a one-line summary of every test binary.
awk '/^test result:/ { p += $4; f += $6 } END { printf "%d passed, %d failed\n", p, f; exit (f > 0) }' target/test-output.txt
