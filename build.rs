//! Build script: checks the build-time settings, and sets up the linker for the firmware.
//!
//! Every `X30_*` variable set for the build is checked with the firmware's own parser (the
//! key table and parsers of `src/settings/text.rs`, included below): an invalid value fails
//! the build, naming the variable and what it allows, rather than leaving the board to fall
//! back to a default nobody sees.
//!
//! Every board keeps its memory layout in its own folder under `src/board/`, none at the
//! package root: the linker looks for `memory.x` in its working directory (the package root)
//! before the search path, so a layout there would override every other board's.
//!
//! It does nothing for hosted targets, so the host workspace (tools/) can build the library
//! without a linker script. For bare-metal targets it copies the selected board's memory layout into `OUT_DIR`,
//! where cortex-m-rt's `link.x` finds it as `memory.x` (and, for a board without a PAC, its
//! interrupt names as `device.x`), and passes the linker scripts to the binary and to the
//! on-target tests only (`rustc-link-arg-bins`, `rustc-link-arg-tests`), so the library and its
//! dependents are unaffected.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

// The codec's number parser and the settings' text, as the firmware compiles them: plain
// `core` Rust, so they build here too. Only part of each is used.
#[allow(dead_code, unused_imports)]
#[path = "src/proto/xml/number/mod.rs"]
mod number;
#[allow(dead_code)]
#[path = "src/settings/text.rs"]
mod text;

/// Link-time description of one board.
struct Board {
    /// Cargo feature that selects the board.
    feature: &'static str,
    /// Memory layout, relative to the package root.
    memory_x: &'static str,
    /// Interrupt names for cortex-m-rt's `device` feature, relative to the package root, for a
    /// board whose HAL does not provide them.
    device_x: Option<&'static str>,
    /// Whether the board logs with defmt, which needs `defmt.x` at link time.
    defmt: bool,
}

/// Every board the firmware supports; a new board adds its feature and layout here.
const BOARDS: &[Board] = &[
    Board {
        feature: "board-nucleo-f767zi",
        memory_x: "src/board/nucleo_f767zi/memory.x",
        // embassy-stm32's PAC provides its own.
        device_x: None,
        defmt: true,
    },
    Board {
        feature: "board-qemu-mps2-an386",
        memory_x: "src/board/qemu_mps2_an386/memory.x",
        device_x: Some("src/board/qemu_mps2_an386/device.x"),
        defmt: false,
    },
];

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    check_settings();

    // Cargo sets CARGO_CFG_TARGET_OS to the target being built, unlike `cfg!` in a build
    // script, which describes the machine running it.
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }

    let selected: Vec<&Board> = BOARDS
        .iter()
        .filter(|board| env::var_os(feature_env(board.feature)).is_some())
        .collect();
    let board = match selected.as_slice() {
        // A library-only build for the target (no board): nothing to link.
        [] => return,
        [board] => *board,
        _ => {
            // An error Cargo shows as it is, without a build-script panic's backtrace.
            println!(
                "cargo::error=select exactly one board feature, got: {}",
                selected
                    .iter()
                    .map(|b| b.feature)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            return;
        }
    };

    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by Cargo"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("set by Cargo"));
    // Copied rather than searched in place so that the files always have the names link.x
    // includes, whichever board's they are.
    copy_script(&manifest_dir, board.memory_x, &out_dir, "memory.x");
    if let Some(device_x) = board.device_x {
        copy_script(&manifest_dir, device_x, &out_dir, "device.x");
    }
    println!("cargo:rustc-link-search={}", out_dir.display());

    // Turns off page alignment of output sections, which the linker otherwise requires of
    // memory regions that do not start on a 64K boundary (cortex-m-quickstart#95).
    link_arg("--nmagic");
    link_arg("-Tlink.x");
    if board.defmt {
        link_arg("-Tdefmt.x");
    }
}

/// Passes a linker argument to the firmware and to the on-target tests (tests/), which are
/// firmware images too.
fn link_arg(arg: &str) {
    println!("cargo:rustc-link-arg-bins={arg}");
    println!("cargo:rustc-link-arg-tests={arg}");
}

/// Copies the linker script `from` (relative to the package root) to `OUT_DIR/to`.
fn copy_script(manifest_dir: &Path, from: &str, out_dir: &Path, to: &str) {
    let source = manifest_dir.join(from);
    println!("cargo:rerun-if-changed={}", source.display());
    if let Err(err) = fs::copy(&source, out_dir.join(to)) {
        panic!("cannot copy {}: {err}", source.display());
    }
}

/// Name of the environment variable through which Cargo announces an enabled feature.
fn feature_env(feature: &str) -> String {
    format!("CARGO_FEATURE_{}", feature.to_uppercase().replace('-', "_"))
}

/// Fails the build on an invalid `X30_*` variable, naming it and what it allows.
fn check_settings() {
    println!("cargo:rerun-if-changed=src/settings/text.rs");
    println!("cargo:rerun-if-changed=src/proto/xml/number");
    let value = |key: text::Key| {
        println!("cargo:rerun-if-env-changed={}", key.variable());
        env::var(key.variable()).ok()
    };
    let mut valid = true;
    let mut values = Vec::new();
    for &key in text::Key::ALL {
        let value = value(key);
        if let Some(text) = &value
            && !key.accepts(text.trim())
        {
            println!(
                "cargo::error={}={:?} is not valid: expected {}",
                key.variable(),
                text,
                key.allowed()
            );
            valid = false;
        }
        values.push((key, value));
    }
    let given = |wanted: text::Key| {
        values
            .iter()
            .find(|(key, _)| *key == wanted)
            .and_then(|(_, value)| value.as_deref().map(str::trim))
    };
    // The one rule between keys: without DHCP the board needs an address of its own.
    let dhcp_off = given(text::Key::Dhcp).and_then(text::parse_switch) == Some(false);
    let ip = given(text::Key::Ip).and_then(|ip| text::optional(ip, text::parse_cidr));
    if valid && dhcp_off && ip.flatten().is_none() {
        println!(
            "cargo::error=X30_DHCP=0 needs X30_IP=a.b.c.d/len: the board would have no address"
        );
    }
}
