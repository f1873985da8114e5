#!/usr/bin/env bash
# Makes docs/web-page.png, the README's picture of the board's status page: the QEMU
# firmware against x30-sim, the page in headless Chromium at a phone's size (430 × 900),
# saved by the web page's end-to-end test (tools/x30-qemu/tests/web.rs) once the page
# shows the simulated robot's battery.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh

out="$PWD/docs/web-page.png"
shot=$(mktemp --suffix=.png)
trap 'rm -f "$shot"' EXIT
# The test skips itself without QEMU or Chromium; then no picture comes, and that fails.
rm -f "$shot"
(cd tools && X30_WEB_SCREENSHOT="$shot" cargo test -p x30-qemu --test web the_page_follows)
[ -s "$shot" ] || { echo "no screenshot was taken" >&2; exit 1; }
mv "$shot" "$out"
echo "wrote $out ($(stat -c %s "$out") bytes)"
