#!/usr/bin/env bash
# Builds the frame_xml fuzz target (host-tests/fuzz, a member of the host workspace in
# tools/) and runs it with libFuzzer, on stable
# Rust: no nightly toolchain and no cargo-fuzz needed. libfuzzer-sys compiles libFuzzer's
# C++ with the system C++ compiler (g++ or clang++; set CXX to choose).
#
#   scripts/fuzz.sh [SECONDS] [extra libFuzzer flags...]
#
# SECONDS defaults to 30. The fuzzer works on a copy of the committed seed corpus in a
# temporary directory, so host-tests/fuzz/corpus/ only changes when someone copies an input
# into it on purpose. Crashing inputs are written to host-tests/fuzz/artifacts/frame_xml/
# (ignored by git); the script then exits non-zero. Reproduce one with
#   tools/target/fuzz/<host>/fuzz/frame_xml <artifact>
set -euo pipefail

DUR="${1:-30}"
shift || true
case "$DUR" in
  '' | *[!0-9]*) echo "usage: $0 [SECONDS] [libFuzzer flags...]" >&2; exit 2 ;;
esac

FUZZ_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/../host-tests/fuzz" && pwd)"
cd "$FUZZ_DIR"

# Coverage instrumentation for libFuzzer, as cargo-fuzz passes it, without needing nightly.
# The crate's .cargo/config.toml names the host target explicitly, so these flags reach only
# the fuzzed code and not build scripts.
export RUSTFLAGS="-Cpasses=sancov-module \
-Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters \
-Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares \
--cfg fuzzing"

# Its own target directory: the coverage flags would otherwise rebuild every dependency of
# the host workspace's other builds, and theirs this one's.
TARGET_DIR="$FUZZ_DIR/../../tools/target/fuzz"
cargo build --profile fuzz -p x30-fuzz --bin frame_xml --target-dir "$TARGET_DIR"

HOST="$(rustc -vV | sed -n 's/^host: //p')"
BIN="$TARGET_DIR/$HOST/fuzz/frame_xml"
ARTIFACTS="$FUZZ_DIR/artifacts/frame_xml"
mkdir -p "$ARTIFACTS"

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
cp -R corpus/frame_xml "$WORK/corpus"

status=0
"$BIN" "$WORK/corpus" \
  -max_total_time="$DUR" \
  -rss_limit_mb=2048 \
  -max_len=8192 \
  -print_final_stats=1 \
  -dict="$FUZZ_DIR/frame_xml.dict" \
  -artifact_prefix="$ARTIFACTS/" \
  "$@" || status=$?

if [ "$status" -ne 0 ]; then
  echo "fuzz.sh: the fuzzer stopped with status $status; crashing inputs are in $ARTIFACTS" >&2
  exit "$status"
fi
echo "fuzz.sh: no crash in ${DUR}s"
