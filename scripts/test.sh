#!/usr/bin/env bash
# Runs every check and test of the project: formatting, lints for the firmware target and
# the host, docs, the firmware build, host tests, the benchmark's allocation check and
# figures, a short fuzz run, and the codec's size. Installs what a fresh Debian machine
# with only the Rust toolchain lacks.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
source scripts/setup.sh

step() { printf '\n=== %s\n' "$*"; }

step "format"
cargo fmt --check
(cd host-tests && cargo fmt --all --check)
(cd host-tests/fuzz && cargo fmt --check)
(cd tools/codec-size && cargo fmt --check)

step "clippy: firmware target (each feature set)"
cargo clippy --release -- -D warnings
cargo clippy --release --lib --features defmt,vendor-extensions -- -D warnings
cargo clippy --release --lib --no-default-features -- -D warnings
cargo clippy --release --no-default-features --features board-qemu-mps2-an386 --bins --tests -- -D warnings

step "clippy: host"
(cd host-tests && cargo clippy --workspace --all-targets -- -D warnings)

step "docs"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --lib --features vendor-extensions

step "firmware build (Nucleo-F767ZI)"
cargo build --release
scripts/firmware-size.sh

step "firmware build (QEMU mps2-an386) and on-target tests in QEMU"
cargo build --release --no-default-features --features board-qemu-mps2-an386
scripts/firmware-size.sh
scripts/qemu-test.sh

step "host tests"
(cd host-tests && cargo test --workspace --all-targets)

step "benchmark (zero allocations asserted; timings reported)"
(cd host-tests && X30_BENCH_QUICK=1 cargo bench --bench codec)

step "fuzz (short run, must find nothing)"
scripts/fuzz.sh "${X30_FUZZ_SECONDS:-30}"

step "codec size"
scripts/codec-size.sh

echo
echo "all checks passed"
