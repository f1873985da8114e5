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

#[cfg(test)]
mod tests {
    use super::*;

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
