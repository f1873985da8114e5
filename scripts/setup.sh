# Sourced by the scripts: makes sure the toolchain pieces and Debian packages are there.
# rust-toolchain.toml names the embedded target; rustup installs it on first use, but an
# explicit call gives a clear error if that is impossible.
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
rustup component add rustfmt clippy >/dev/null 2>&1 || true
# The firmware's linker (.cargo/config.toml): zero-cost stack overflow protection.
command -v flip-link >/dev/null 2>&1 || cargo install --locked flip-link

# apt_need PACKAGE COMMAND: installs PACKAGE when COMMAND is missing.
apt_need() {
    command -v "$2" >/dev/null 2>&1 && return 0
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "installing $1 (for $2)"
    $sudo apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "$1" >/dev/null
}
apt_need llvm llvm-size
apt_need g++ g++
# The QEMU board's firmware, its on-target tests, and the virtual panel (x30-qemu, its
# end-to-end tests and the demo) run in QEMU.
apt_need qemu-system-arm qemu-system-arm
# The web page's end-to-end test (tools/x30-qemu/tests/web.rs) and its screenshot
# (scripts/web-screenshot.sh) open the page in headless Chromium through chromedriver.
apt_need chromium chromium
apt_need chromium-driver chromedriver
