#!/usr/bin/env bash
# The main job: builds the Nucleo-F767ZI firmware and reports its flash and static RAM.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
cargo build --release
scripts/firmware-size.sh
