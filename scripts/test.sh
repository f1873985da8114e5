#!/usr/bin/env bash
# Runs every check and test of the project: formatting, lints for the firmware target and
# the host, docs, the firmware builds, host tests (including the end-to-end tests in QEMU),
# the benchmark's allocation check and figures, a short fuzz run, and the codec's size and
# instruction counts on the microcontroller.
# Installs what a fresh Debian machine with only the Rust toolchain lacks.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
source scripts/setup.sh

# Each step's header says how long the run has taken so far, to show where CI time goes.
step() { printf '\n=== %s (at %d s)\n' "$*" "$SECONDS"; }

step "format"
cargo fmt --all --check
(cd tools && cargo fmt --all --check)

step "clippy: firmware target (each feature set)"
cargo clippy --release --features board-nucleo-f767zi -- -D warnings
cargo clippy --release --features board-qemu-mps2-an386 --bins --tests -- -D warnings
cargo clippy --release --lib -- -D warnings
cargo clippy --release --lib --features defmt,vendor-extensions -- -D warnings
cargo clippy --release --lib --features serde,vendor-extensions -- -D warnings
cargo clippy --release -p x30-codec-size --features robot-side -- -D warnings
cargo clippy --release -p x30-codec-size --features robot-side,compact -- -D warnings
cargo clippy --release -p x30-codec-count -- -D warnings
cargo clippy --release -p x30-codec-count --features robot-side,compact -- -D warnings

step "clippy: host"
(cd tools && cargo clippy --workspace --all-targets -- -D warnings)

step "docs"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --lib --features vendor-extensions

step "firmware build (Nucleo-F767ZI)"
cargo build-nucleo
scripts/firmware-size.sh
# The QEMU board's runner refuses this image, which the QEMU build's path now holds.
status=0
X30_QEMU_TIMEOUT=10 scripts/qemu-run.sh target/thumbv7em-none-eabihf/release/x30-panel \
    2> /dev/null || status=$?
[ "$status" = 2 ] || { echo "qemu-run.sh ran the Nucleo image (status $status)" >&2; exit 1; }
# Two boards at once is a build error naming both (build.rs), not a build-script panic.
both=board-nucleo-f767zi,board-qemu-mps2-an386
errors=$(cargo build --release --features "$both" 2>&1) && exit 1
grep -q "error: .*select exactly one board feature, got: ${both/,/, }$" <<< "$errors" ||
    { echo "$errors" >&2; echo "no build error naming both boards" >&2; exit 1; }

step "firmware build (QEMU mps2-an386) and on-target tests in QEMU"
cargo build-qemu
scripts/firmware-size.sh
scripts/qemu-test.sh

step "host tests of the core, with the firmware's protocol surface (no vendor-extensions)"
# Eight tests at a time: the application's tests spend their time waiting on the simulated
# robot (75 s one or two at a time, under 30 s eight at a time, on next to no CPU).
(cd tools && RUST_TEST_THREADS=8 cargo test -p x30-host-tests --all-targets)

step "host tests of the codec, compact build (its fast paths left out)"
(cd tools && cargo test -p x30-host-tests --features compact --test messages --test xml \
    --test number --test frame --test properties --test errors --test codes --test time)

step "host tests of the tools (with the end-to-end tests: the QEMU firmware against x30-sim)"
(cd tools && cargo test --workspace --all-targets --exclude x30-host-tests --exclude x30-fuzz)

step "the README's cargo run lines start (--help)"
# A package with a second binary needs `default-run` for these lines to work as written.
for package in $(grep -o 'cargo run -p [a-z0-9-]*' README.md | awk '{ print $4 }' | sort -u); do
    (cd tools && cargo run -q -p "$package" -- --help > /dev/null)
done

step "end-to-end tests again, with the codec's compact build in the firmware"
# The build that meets the codec's flash targets, on the target against x30-sim. It replaces
# the firmware ELF of the steps above, which none of the steps below use.
(cd tools && X30_FIRMWARE_FEATURES=compact cargo test -p x30-qemu --test e2e)

step "benchmark (zero allocations asserted; timings reported)"
# The summary with the README's budget (41 samples of each side, not the quick run's 15): a
# few seconds more, and a busy spell of a shared machine is less likely to last through
# every sample of one side.
(cd tools && cargo bench -p x30-host-tests --bench codec)

step "fuzz (short run, must find nothing)"
scripts/fuzz.sh "${X30_FUZZ_SECONDS:-30}"

step "codec size"
scripts/codec-size.sh
scripts/codec-size.sh --parts

step "codec instructions on the microcontroller (in QEMU)"
scripts/codec-count.sh

echo
echo "all checks passed in $SECONDS s"
