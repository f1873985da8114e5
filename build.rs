//! Build script: linker setup for the firmware binary.
//!
//! It does nothing for hosted targets, so host-tests/ can build the library without a linker
//! script. For bare-metal targets it copies the selected board's memory layout into `OUT_DIR`,
//! where cortex-m-rt's `link.x` finds it as `memory.x`, and passes the linker scripts to the
//! binary only (`rustc-link-arg-bins`), so the library and its dependents are unaffected.

use std::env;
use std::fs;
use std::path::PathBuf;

/// Link-time description of one board.
struct Board {
    /// Cargo feature that selects the board.
    feature: &'static str,
    /// Memory layout, relative to the package root.
    memory_x: &'static str,
    /// Whether the board logs with defmt, which needs `defmt.x` at link time.
    defmt: bool,
}

/// Every board the firmware supports; a new board adds its feature and layout here.
const BOARDS: &[Board] = &[Board {
    feature: "board-nucleo-f767zi",
    memory_x: "memory.x",
    defmt: true,
}];

fn main() {
    println!("cargo:rerun-if-changed=build.rs");

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
        _ => panic!(
            "select exactly one board feature, got: {}",
            selected
                .iter()
                .map(|b| b.feature)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };

    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by Cargo"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("set by Cargo"));
    let layout = manifest_dir.join(board.memory_x);
    println!("cargo:rerun-if-changed={}", layout.display());
    // Copied rather than searched in place so that the file is always named `memory.x`,
    // whichever board's layout it is.
    if let Err(err) = fs::copy(&layout, out_dir.join("memory.x")) {
        panic!("cannot copy {}: {err}", layout.display());
    }
    println!("cargo:rustc-link-search={}", out_dir.display());

    // Turns off page alignment of output sections, which the linker otherwise requires of
    // memory regions that do not start on a 64K boundary (cortex-m-quickstart#95).
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    if board.defmt {
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}

/// Name of the environment variable through which Cargo announces an enabled feature.
fn feature_env(feature: &str) -> String {
    format!("CARGO_FEATURE_{}", feature.to_uppercase().replace('-', "_"))
}
