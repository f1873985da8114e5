//! Links the program for QEMU's mps2-an386 machine: cortex-m-rt's `link.x` with the QEMU
//! board's memory layout.

use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let board = manifest.join("../../src/board/qemu_mps2_an386");
    println!("cargo:rustc-link-search={}", board.display());
    println!(
        "cargo:rerun-if-changed={}",
        board.join("memory.x").display()
    );
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
