#!/usr/bin/env bash
# Builds the QEMU mps2-an386 firmware and runs the on-target tests (tests/) in QEMU.
#
# .cargo/config.toml's runner is probe-rs, for the Nucleo; this points Cargo at
# scripts/qemu-run.sh instead, so the tests boot in QEMU and QEMU's exit status (the test's
# semihosting exit) is the test's result. Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

if ! command -v qemu-system-arm >/dev/null; then
    echo "qemu-system-arm not found: apt-get install qemu-system-arm" >&2
    exit 127
fi

features=(--features board-qemu-mps2-an386)
cargo build --release "${features[@]}"
# A hung test fails instead of blocking CI; the smoke test takes a few seconds.
X30_QEMU_TIMEOUT=${X30_QEMU_TIMEOUT:-120} \
    cargo test --release "${features[@]}" --test qemu_smoke \
    --config "target.thumbv7em-none-eabihf.runner = \"$root/scripts/qemu-run.sh\"" "$@" </dev/null
