#!/usr/bin/env bash
# The project's test command: formatting, lints, the no_std build for the
# Cortex-M4F target, the C header check, then the host test suite (firmware
# and C example under QEMU included; its summary is the last line).
set -euo pipefail
cd "$(dirname "$0")/.."

# A check runs from scratch: incremental caches would only fill the disk
# (1.9 GB on a clean run), and a CI machine's disk once ran out.
export CARGO_INCREMENTAL=0

# Each stage's header says when it began (s since the start), so a CI log
# shows where the time goes.
stage() { echo "== [${SECONDS} s] $*"; }

# A full disk fails a late stage with an unrelated error (pip's "No space
# left on device" after 23 minutes once): say at the start what is free.
stage "disk: $(df -h --output=avail . 2>/dev/null | tail -1 | tr -d ' ') free at the start"

# rust-toolchain.toml pins the toolchain, the thumbv7em-none-eabihf target
# and the clippy/rustfmt/llvm-tools components; rustup installs them on first
# use. Make sure they are present even with an older rustup.
if command -v rustup >/dev/null 2>&1; then
  rustup show active-toolchain >/dev/null
  rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
  rustup component add clippy rustfmt llvm-tools >/dev/null 2>&1 || true
fi

# The firmware runs under QEMU (mps2-an386) in the tests; its log is decoded
# by defmt-print (installed once into ~/.cargo/bin, then reused).
if ! command -v qemu-system-arm >/dev/null 2>&1; then
  stage "installing qemu-system-arm"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y --no-install-recommends qemu-system-arm >/dev/null
fi
if ! command -v defmt-print >/dev/null 2>&1; then
  stage "installing defmt-print"
  cargo install defmt-print --version 1.2.0 --locked --quiet
fi

# The C example firmware (examples/c/) is built with arm-none-eabi-gcc.
if ! command -v arm-none-eabi-gcc >/dev/null 2>&1; then
  stage "installing gcc-arm-none-eabi"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y --no-install-recommends gcc-arm-none-eabi >/dev/null
fi

stage "cargo fmt --check"
cargo fmt --all --check
stage "layout: no import circles between modules, no file over 800 lines without a reason"
python3 scripts/layout_check.py estimator-core fracbms-host host-sim estimator-ffi firmware xtask python tests
stage "cargo clippy (host crates and the Python extension, all targets)"
cargo clippy --all-targets -- -D warnings
cargo clippy -p fracbms-python --all-targets -- -D warnings
stage "cargo doc: the host crates' and the core's API docs, every intra-doc link resolved"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps -p estimator-core -p fracbms-host -p host-sim -p estimator-ffi -p firmware
stage "no_std build: estimator-core for thumbv7em-none-eabihf"
cargo build -p estimator-core --target thumbv7em-none-eabihf --release
cargo clippy -p estimator-core --target thumbv7em-none-eabihf -- -D warnings
stage "C ABI: the static library for thumbv7em-none-eabihf, and include/fracbms.h up to date"
cargo clippy -p estimator-ffi --target thumbv7em-none-eabihf --release -- -D warnings
cargo build -p estimator-ffi --target thumbv7em-none-eabihf --release
cargo xtask header --check
stage "firmware for the STM32L452 board (built, not run: no board here), with clippy"
for f in board-stm32l452 stm32l452-bq769x0; do
  cargo clippy -p firmware --target thumbv7em-none-eabihf --release --no-default-features --features "$f" -- -D warnings
  cargo build -p firmware --target thumbv7em-none-eabihf --release --no-default-features --features "$f"
done
stage "firmware for thumbv7em-none-eabihf (QEMU board), with clippy"
cargo clippy -p firmware --target thumbv7em-none-eabihf --release -- -D warnings
cargo build -p firmware --target thumbv7em-none-eabihf --release
stage "no panic path in the firmware's sample step (docs/panic-paths.md): the default image, and one with an OCV table, Butler-Volmer and the tail"
cargo xtask panic-sites --deny-reachable | tail -1
FRACBMS_REPLAY="$PWD/data/pybamm/chen2020-hppc.csv" FRACBMS_OCV="$PWD/data/pybamm/chen2020-ocv.csv" \
  FRACBMS_CAPACITY_AH=5.153198 FRACBMS_MODEL=butler-volmer FRACBMS_TAIL=1 \
  cargo xtask panic-sites --deny-reachable | tail -1
# The tests run to the end even when some fail, so that the summary below
# counts them all.
set +e
stage "cargo test --no-run: the host crates' tests and binaries (dev profile)"
cargo test --workspace --no-run
build_status=$?
# The two reference checks run cargo test's own host-sim: their results are
# the release build's to the bit (no fast-math), and a release build of it
# for them alone took 7 min of a CI run.
checks_status=0
HOST_SIM="${CARGO_TARGET_DIR:-target}/debug/host-sim"
if [ "$build_status" -eq 0 ]; then
  stage "numpy reference of the battery 2S-OP-GI iteration agrees with host-sim to 1e-9"
  python3 -c "import numpy" 2>/dev/null || python3 -m pip install --quiet numpy
  python3 bench/compare.py --runs 1 --iterations 100 --host-sim "$HOST_SIM" || checks_status=1
  stage "the Hammerstein refinement reaches the independent maximum-likelihood reference (scipy)"
  python3 -c "import scipy" 2>/dev/null || python3 -m pip install --quiet scipy
  python3 bench/hammerstein_reference_check.py --host-sim "$HOST_SIM" || checks_status=1
fi
stage "cargo test (host crates, CLI end to end, firmware under QEMU)"
cargo test --workspace 2>&1 | tee target/test-output.txt
cargo_status=${PIPESTATUS[0]}
if [ "$checks_status" -ne 0 ]; then
  echo "test result: FAILED. 0 passed; 1 failed; (bench/compare.py, bench/hammerstein_reference_check.py)" >> target/test-output.txt
fi

stage "Python: pip install ./python into a new virtual environment, then pytest python/tests"
# The package is built once (maturin, profile `dev`, below) and its tests compare
# it with the host-sim binary cargo test has just built.
python_status=0
PYVENV=target/python-venv
rm -rf "$PYVENV"
if ! python3 -m venv "$PYVENV" 2>/dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq && $SUDO apt-get install -y --no-install-recommends python3-venv >/dev/null
  python3 -m venv "$PYVENV"
fi
# pandas and dask[distributed]: fracbms.fleet's test on a LocalCluster, which
# must run here (FRACBMS_REQUIRE_FLEET: not skipped).
"$PYVENV/bin/python" -m pip install --quiet numpy pytest pandas "dask[distributed]" || python_status=1
start=$(date +%s)
# In the dev profile (maturin's `--profile dev`): its dependencies are those
# `cargo test --workspace` has just built, where the package's own `python`
# profile builds them all again with LTO (350 s of a CI run, against 180 s;
# the tests then take 51 s instead of 41 s). The arithmetic is the same (no
# fast-math); a user's `pip install ./python` builds the `python` profile.
if MATURIN_PEP517_ARGS="--profile dev" "$PYVENV/bin/python" -m pip install --quiet ./python; then
  echo "pip install ./python: built and installed in $(( $(date +%s) - start )) s"
  # The parity test's C face links the dev-profile libfracbms.a that the
  # host C test has built (a release build of it for this alone: 6 min).
  cargo build -p host-sim -p estimator-ffi --quiet
  FRACBMS_REQUIRE_FLEET=1 FRACBMS_HOST_SIM="$PWD/target/debug/host-sim" \
    FRACBMS_C_LIB="$PWD/target/debug/libfracbms.a" "$PYVENV/bin/pytest" -q python/tests \
    --junitxml=target/pytest.xml -p no:cacheprovider || python_status=1
  # pytest's counts in cargo's format, for the summary.
  "$PYVENV/bin/python" - <<'PY' >> target/test-output.txt
import xml.etree.ElementTree as ET
s = ET.parse("target/pytest.xml").getroot()
s = s if s.tag == "testsuite" else s.find("testsuite")
n, f, e, k = (int(s.get(a, 0)) for a in ("tests", "failures", "errors", "skipped"))
print(f"test result: pytest. {n - f - e - k} passed; {f + e} failed; {k} skipped (python/tests)")
PY
else
  python_status=1
  echo "test result: FAILED. 0 passed; 1 failed; (pip install ./python)" >> target/test-output.txt
fi
set -e
stage "disk: target/ holds $(du -sh target 2>/dev/null | cut -f1) after the run"

# Finish on a one-line summary of every test binary and of pytest (a cargo
# test run that did not finish counts as one failure).
awk -v cargo="$cargo_status" -v py="$python_status" '
  /^test result:/ { p += $4; f += $6 }
  END {
    if (cargo != 0 && f == 0) f = 1
    if (py != 0 && f == 0) f = 1
    printf "%d passed, %d failed\n", p, f
    exit (f > 0)
  }' target/test-output.txt
