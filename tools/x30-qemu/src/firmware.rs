//! Building the QEMU firmware image with Cargo.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The firmware's board feature for QEMU's mps2-an386 machine.
pub const BOARD_FEATURE: &str = "board-qemu-mps2-an386";

/// Names more features for the firmware's build, comma-separated: `compact` builds the codec
/// without its fast paths, as a microcontroller short of flash would.
pub const FEATURES_VARIABLE: &str = "X30_FIRMWARE_FEATURES";

/// The firmware's binary target.
const BIN: &str = "x30-panel";

/// The charging point the virtual panel's `dock` button walks to, unless `X30_DOCK` is set:
/// 5 m ahead of the simulator's start, far enough that a task is still running a few
/// seconds later. The firmware itself has no default point (no place is safe to assume).
pub const DEMO_DOCK: &str = "1,1,5.0,0,0,0";

/// The repository root (the firmware crate), as it was when x30-qemu was compiled: two
/// levels above this crate.
pub fn repository_root() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    root.canonicalize().unwrap_or(root)
}

/// Builds the firmware for the QEMU board (a no-op when it is up to date) and returns the
/// ELF's path. Cargo's progress and diagnostics go to standard error as usual.
///
/// Cargo runs in the repository root because it reads `.cargo/config.toml` from its working
/// directory upwards: the root's config is what selects the Cortex-M target, the linker
/// script arguments come from build.rs. The ELF's path is taken from Cargo's JSON messages
/// rather than guessed, so a `CARGO_TARGET_DIR` in the environment is honoured.
pub fn build(root: &Path) -> Result<PathBuf, String> {
    let manifest = root.join("Cargo.toml");
    let features = features();
    let mut command = Command::new("cargo");
    command
        .current_dir(root)
        .args(["build", "--release", "--features"])
        .arg(&features)
        .args(["--bin", BIN, "--message-format=json-render-diagnostics"])
        .env(
            "X30_DOCK",
            std::env::var("X30_DOCK").unwrap_or_else(|_| DEMO_DOCK.into()),
        )
        .arg("--manifest-path")
        .arg(&manifest)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    let mut child = command
        .spawn()
        .map_err(|e| format!("cannot run cargo to build the firmware: {e}"))?;
    let mut elf = None;
    if let Some(stdout) = child.stdout.take() {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if let Some(path) = executable(&line) {
                elf = Some(path);
            }
        }
    }
    let status = child
        .wait()
        .map_err(|e| format!("cannot wait for cargo: {e}"))?;
    if !status.success() {
        return Err(format!(
            "building the firmware failed ({status}): cargo build --release \
             --features {features} --manifest-path {}",
            manifest.display()
        ));
    }
    elf.ok_or_else(|| "cargo built the firmware but did not say where the ELF is".into())
}

/// The features the firmware is built with: the board's, and those [`FEATURES_VARIABLE`]
/// adds.
pub fn features() -> String {
    with_extra(std::env::var(FEATURES_VARIABLE).ok().as_deref())
}

/// The board's feature followed by `extra`, if it names any.
fn with_extra(extra: Option<&str>) -> String {
    match extra.map(str::trim) {
        Some(extra) if !extra.is_empty() => format!("{BOARD_FEATURE},{extra}"),
        _ => BOARD_FEATURE.to_string(),
    }
}

/// The firmware executable named by one of Cargo's JSON messages, if it names it.
fn executable(message: &str) -> Option<PathBuf> {
    let message: serde_json::Value = serde_json::from_str(message).ok()?;
    if message["reason"] != "compiler-artifact" || message["target"]["name"] != BIN {
        return None;
    }
    message["executable"].as_str().map(PathBuf::from)
}

/// Where the QEMU board's code memory ends: 4 MiB from address 0 (its memory layout), where
/// QEMU loads the ELF and where its entry point must lie.
const CODE_END: u32 = 0x0040_0000;

/// Checks that the file at `elf` can be the QEMU board's firmware: a 32-bit little-endian
/// Arm ELF whose entry point lies in the board's code memory. A Nucleo build (the same path
/// as the QEMU build's) or any other file would make QEMU stop at once with a CPU lockup
/// and a register dump, which names neither the file nor the mistake.
pub fn check(elf: &Path) -> Result<(), String> {
    let mut header = [0u8; 28];
    let read = std::fs::File::open(elf).and_then(|mut file| {
        use std::io::Read;
        file.read_exact(&mut header)
    });
    let shown = elf.display();
    let build = "build it with `cargo build-qemu`, or leave --firmware out";
    if read.is_err() || header[..4] != *b"\x7fELF" {
        return Err(format!("--firmware {shown}: not an ELF file; {build}"));
    }
    // ELF32 (class 1), little-endian (data 1), machine 40: Arm.
    let machine = u16::from_le_bytes([header[18], header[19]]);
    if header[4] != 1 || header[5] != 1 || machine != 40 {
        return Err(format!("--firmware {shown}: not a 32-bit Arm ELF; {build}"));
    }
    let entry = u32::from_le_bytes([header[24], header[25], header[26], header[27]]);
    if entry >= CODE_END {
        return Err(format!(
            "--firmware {shown}: its entry point {entry:#010x} is outside the QEMU board's \
             code memory (below {CODE_END:#x}): a Nucleo build? Both boards' builds write \
             target/thumbv7em-none-eabihf/release/x30-panel; {build}"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An ELF32 header's first 28 bytes: `class`, `data`, `machine` and `entry` as given.
    fn header(class: u8, data: u8, machine: u16, entry: u32) -> Vec<u8> {
        let mut bytes = vec![0u8; 52];
        bytes[..4].copy_from_slice(b"\x7fELF");
        (bytes[4], bytes[5]) = (class, data);
        bytes[18..20].copy_from_slice(&machine.to_le_bytes());
        bytes[24..28].copy_from_slice(&entry.to_le_bytes());
        bytes
    }

    #[test]
    fn only_an_arm_elf_for_the_boards_code_memory_passes() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("x30-panel");
        let cases: [(Vec<u8>, Option<&str>); 6] = [
            (header(1, 1, 40, 0x0000_0401), None),
            (
                header(1, 1, 40, 0x0800_0199),
                Some("outside the QEMU board's code memory"),
            ),
            (header(2, 1, 40, 0x401), Some("not a 32-bit Arm ELF")),
            (header(1, 1, 62, 0x401), Some("not a 32-bit Arm ELF")),
            (
                b"root:x:0:0:root:/root:/bin/bash\n".to_vec(),
                Some("not an ELF file"),
            ),
            (b"\x7fEL".to_vec(), Some("not an ELF file")),
        ];
        for (bytes, problem) in cases {
            std::fs::write(&file, &bytes).unwrap();
            match (check(&file), problem) {
                (Ok(()), None) => {}
                (Err(e), Some(problem)) => assert!(e.contains(problem), "{e}"),
                (result, _) => panic!("{bytes:?}: {result:?}, expected {problem:?}"),
            }
        }
        assert!(check(&dir.path().join("missing")).is_err());
    }

    #[test]
    fn root_holds_the_firmware_crate() {
        let root = repository_root();
        let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
        assert!(manifest.contains("name = \"x30-panel\""));
        assert!(root.join(".cargo/config.toml").is_file());
    }

    #[test]
    fn extra_features_follow_the_boards() {
        assert_eq!(with_extra(None), BOARD_FEATURE);
        assert_eq!(with_extra(Some(" ")), BOARD_FEATURE);
        assert_eq!(
            with_extra(Some("compact")),
            format!("{BOARD_FEATURE},compact")
        );
    }

    #[test]
    fn executable_from_json() {
        let artifact = r#"{"reason":"compiler-artifact","target":{"name":"x30-panel","kind":["bin"]},"executable":"/r/target/thumbv7em-none-eabihf/release/x30-panel","fresh":true}"#;
        assert_eq!(
            executable(artifact),
            Some(PathBuf::from(
                "/r/target/thumbv7em-none-eabihf/release/x30-panel"
            ))
        );
        let lib = r#"{"reason":"compiler-artifact","target":{"name":"x30_panel","kind":["lib"]},"executable":null}"#;
        assert_eq!(executable(lib), None);
        assert_eq!(
            executable(r#"{"reason":"build-finished","success":true}"#),
            None
        );
        assert_eq!(executable("not json"), None);
    }
}
