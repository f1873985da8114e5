#!/usr/bin/env bash
# Builds the fuzz targets (host-tests/fuzz, a member of the host workspace in tools/) and
# runs each with libFuzzer, on stable Rust: no nightly toolchain and no cargo-fuzz needed.
# libfuzzer-sys compiles libFuzzer's C++ with the system C++ compiler (g++ or clang++; set
# CXX to choose).
#
#   scripts/fuzz.sh [SECONDS] [extra libFuzzer flags...]
#
# The targets: frame_xml (frame decoder and both message decoders on a byte stream),
# field_input (the console's lines, the settings form and settings blobs from the flash: no
# panic, and whatever they leave in the settings is stored and read back as it is) and
# read_paths (the reader's layout shortcuts against its general path, the answers' writer
# against its general path, decode(encode(x)) == x, and the number text against Rust's own).
# Each runs for SECONDS, default 30, beside the others, first against the codec as the boards build it, then against its `compact` build (the one
# that meets the flash targets, whose reader and number text take other code). The fuzzer
# works on a copy of the committed seed corpus (host-tests/fuzz/corpus/<target>/, written by
# gen_corpus.py) in a temporary directory, so the corpus only changes when someone copies an
# input into it on purpose. Crashing inputs are written to
# host-tests/fuzz/artifacts/<build>/<target>/ (ignored by git); the script then exits
# non-zero, leaving the build that crashed in place: reproduce one with
#   tools/target/fuzz/<host>/fuzz/<target> <artifact>
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

HOST="$(rustc -vV | sed -n 's/^host: //p')"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

# The fuzz builds in a target directory of their own: the coverage flags would otherwise
# rebuild every dependency of the host workspace's other builds, and theirs these. The two
# builds share it (and their dependencies); the second replaces the first's binaries.
TARGET_DIR="$FUZZ_DIR/../../tools/target/fuzz"
TARGETS=(frame_xml read_paths field_input)
# The libFuzzer dictionary of target "$1": the protocol's vocabulary for the codec's targets.
dict_of() { if [ "$1" = field_input ]; then echo field_input.dict; else echo frame_xml.dict; fi; }
for build in default compact; do
  features=()
  [ "$build" = compact ] && features=(--features x30-panel/compact)
  cargo build --profile fuzz -p x30-fuzz --bins --target-dir "$TARGET_DIR" "${features[@]}"

  # The three targets fuzz side by side, each for SECONDS; each one's output goes
  # to a log of its own, printed whole if it found something and its final figures otherwise.
  pids=()
  for target in "${TARGETS[@]}"; do
    BIN="$TARGET_DIR/$HOST/fuzz/$target"
    ARTIFACTS="$FUZZ_DIR/artifacts/$build/$target"
    mkdir -p "$ARTIFACTS"
    rm -rf "${WORK:?}/$target"
    cp -R "corpus/$target" "$WORK/$target"
    "$BIN" "$WORK/$target" \
      -max_total_time="$DUR" \
      -rss_limit_mb=2048 \
      -max_len=8192 \
      -print_final_stats=1 \
      -dict="$FUZZ_DIR/$(dict_of "$target")" \
      -artifact_prefix="$ARTIFACTS/" \
      "$@" > "$WORK/$target.log" 2>&1 &
    pids+=("$!")
  done
  failed=0
  for target in "${TARGETS[@]}"; do
    status=0
    wait "${pids[0]}" || status=$?
    pids=("${pids[@]:1}")
    if [ "$status" -ne 0 ]; then
      cat "$WORK/$target.log"
      echo "fuzz.sh: $target ($build build) stopped with status $status; crashing inputs are in $FUZZ_DIR/artifacts/$build/$target" >&2
      failed=$status
    else
      grep -E '^(Done |stat::)' "$WORK/$target.log" || true
      echo "fuzz.sh: $target ($build build): no crash in ${DUR}s"
    fi
  done
  [ "$failed" -eq 0 ] || exit "$failed"
done
