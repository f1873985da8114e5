//! QEMU's command line, and starting it so that it never outlives x30-qemu.

use std::env;
use std::ffi::{OsStr, OsString};
use std::fs;
use std::io;
use std::net::{Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// The host as QEMU's user networking (slirp) shows it to the guest: connections to
/// 10.0.2.2 reach the host's 127.0.0.1.
pub const GUEST_HOST: Ipv4Addr = Ipv4Addr::new(10, 0, 2, 2);

/// The address the firmware must dial to reach a robot at `robot` on this machine.
///
/// Only `127.0.0.1:PORT` (or `localhost:PORT`) is accepted: slirp forwards 10.0.2.2 to
/// exactly that address, so any other robot would be unreachable from the guest, and the
/// virtual panel is for simulators, never for driving a real robot on the network.
pub fn guest_robot(robot: &str) -> Result<SocketAddr, String> {
    let port = loopback_port(robot).map_err(|why| {
        format!(
            "--robot {robot}: {why}; the virtual panel reaches only a robot on this machine's \
             loopback, 127.0.0.1:PORT (QEMU's user network maps 10.0.2.2 to 127.0.0.1)"
        )
    })?;
    Ok(SocketAddr::new(GUEST_HOST.into(), port))
}

/// The firmware's web page port, in the guest.
pub const GUEST_HTTP_PORT: u16 = 80;

/// The host port that `--http` forwards to the firmware's web page.
///
/// Only `127.0.0.1:PORT` (or `localhost:PORT`) is accepted: the virtual panel's page, and
/// its settings form, are for this machine alone, never for the network.
pub fn http_port(http: &str) -> Result<u16, String> {
    loopback_port(http).map_err(|why| {
        format!(
            "--http {http}: {why}; the page is forwarded only to this machine's loopback, \
             127.0.0.1:PORT"
        )
    })
}

/// The port of `address`, which must be `127.0.0.1:PORT` or `localhost:PORT` with a port
/// other than 0; else why not.
fn loopback_port(address: &str) -> Result<u16, &'static str> {
    let port = match address.parse::<SocketAddr>() {
        Ok(SocketAddr::V4(addr)) if *addr.ip() == Ipv4Addr::LOCALHOST => addr.port(),
        Ok(_) => return Err("not 127.0.0.1"),
        Err(_) => match address.strip_prefix("localhost:").map(str::parse::<u16>) {
            Some(Ok(port)) => port,
            _ => return Err("not an address of the form 127.0.0.1:PORT"),
        },
    };
    if port == 0 {
        return Err("port 0 is not a usable port");
    }
    Ok(port)
}

/// The longest settings file path the firmware takes, in bytes.
const MAX_SETTINGS_PATH: usize = 255;

/// The file behind the firmware's settings flash, as an absolute path (the firmware opens it
/// from QEMU's point of view): `named` (created empty if it does not exist), else a fresh
/// `settings.bin` in `dir`.
///
/// The path travels on the semihosting command line, whose arguments are separated by
/// spaces, so it may not contain whitespace; the firmware takes up to 255 bytes of UTF-8.
pub fn settings_file(named: Option<&Path>, dir: &Path) -> Result<PathBuf, String> {
    let path = named.map_or_else(|| dir.join("settings.bin"), Path::to_owned);
    let shown = path.display();
    let path = std::path::absolute(&path).map_err(|e| format!("--settings {shown}: {e}"))?;
    let text = path
        .to_str()
        .ok_or_else(|| format!("--settings {shown}: the path is not UTF-8"))?;
    if text.contains(char::is_whitespace) {
        return Err(format!(
            "--settings {shown}: the path contains whitespace, which the firmware's command \
             line cannot carry"
        ));
    }
    if text.len() > MAX_SETTINGS_PATH {
        return Err(format!(
            "--settings {shown}: the path is longer than {MAX_SETTINGS_PATH} bytes"
        ));
    }
    // Created if missing, never truncated: an empty file is a blank flash, and a saved one
    // must survive.
    fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&path)
        .map_err(|e| format!("--settings {shown}: cannot open or create it: {e}"))?;
    Ok(path)
}

/// `value` for a QEMU option list, where a comma separates options unless doubled.
fn option_value(value: &OsStr) -> OsString {
    use std::os::unix::ffi::{OsStrExt, OsStringExt};
    let mut escaped = Vec::with_capacity(value.len());
    for &byte in value.as_bytes() {
        escaped.push(byte);
        if byte == b',' {
            escaped.push(b',');
        }
    }
    OsString::from_vec(escaped)
}

/// `prefix` followed by `value` escaped for a QEMU option list.
fn option(prefix: &str, value: &OsStr) -> OsString {
    let mut option = OsString::from(prefix);
    option.push(option_value(value));
    option
}

/// QEMU's arguments: the mps2-an386 machine, its LAN9118 on user networking (forwarding
/// the host's 127.0.0.1:`http` to the web page, if given), UART0 on QEMU's standard input
/// and output, UART1 (the serial console) on the Unix socket `console` (QEMU connects to
/// it), semihosting passing the robot's address and the settings file as the firmware's
/// command line, no monitor (its prompt would mix with the output and eat input), and the
/// firmware ELF. `extra` goes last, so that it can add to or override what comes before.
pub fn args(
    elf: &Path,
    guest_robot: SocketAddr,
    settings: &Path,
    console: &Path,
    http: Option<u16>,
    extra: &[String],
) -> Vec<OsString> {
    let mut args: Vec<OsString> = ["-M", "mps2-an386", "-nographic", "-monitor", "none"]
        .into_iter()
        .map(OsString::from)
        .collect();
    args.push("-chardev".into());
    args.push(option("socket,id=console,path=", console.as_os_str()));
    // The N-th -serial is UART N.
    args.extend(["-serial", "stdio", "-serial", "chardev:console"].map(OsString::from));
    args.push("-semihosting-config".into());
    args.push(option(
        &format!("enable=on,target=native,arg=x30-panel,arg={guest_robot},arg=settings="),
        settings.as_os_str(),
    ));
    let mut nic = String::from("user,model=lan9118");
    if let Some(port) = http {
        nic.push_str(&format!(",hostfwd=tcp:127.0.0.1:{port}-:{GUEST_HTTP_PORT}"));
    }
    args.extend(["-nic".into(), nic.into(), "-kernel".into()]);
    args.push(elf.into());
    args.extend(extra.iter().map(OsString::from));
    args
}

/// Where `program` is: itself if it names a path, else the first executable of that name
/// on `PATH`; `None` if there is none.
pub fn find(program: &Path) -> Option<PathBuf> {
    if program.components().count() > 1 {
        return is_executable(program).then(|| program.to_owned());
    }
    env::split_paths(&env::var_os("PATH")?)
        .map(|dir| dir.join(program))
        .find(|path| is_executable(path))
}

fn is_executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    path.metadata()
        .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

/// Starts QEMU with every standard stream piped to x30-qemu.
///
/// QEMU gets a process group of its own, so a Ctrl-C typed in the terminal reaches only
/// x30-qemu, which then stops QEMU itself and reports the interruption; otherwise QEMU
/// would quit on its own and its exit could pass for the firmware's. On Linux it is also
/// killed if x30-qemu dies without cleaning up (SIGKILL, a crash), so no orphan keeps
/// the robot's port busy.
pub fn spawn(program: &Path, args: &[OsString]) -> io::Result<Child> {
    use std::os::unix::process::CommandExt;
    let mut command = Command::new(program);
    command
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0);
    die_with_parent(&mut command);
    command.spawn()
}

/// Makes the child get SIGKILL when this process dies.
///
/// The signal follows the *thread* that spawned the child, so QEMU must be spawned from
/// the main thread, which lives as long as the process.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn die_with_parent(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    // `std::process::id` before the fork: the child compares its parent with it.
    let parent = std::process::id();
    // SAFETY: the closure runs in the forked child before exec, where only async-signal-safe
    // calls are allowed: prctl and getppid are system calls, and the errors are built
    // without allocating.
    unsafe {
        command.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL as libc::c_ulong) != 0 {
                return Err(io::Error::last_os_error());
            }
            // The parent may have died between fork and prctl; then nobody would send it.
            if libc::getppid() as u32 != parent {
                return Err(io::Error::from_raw_os_error(libc::ESRCH));
            }
            Ok(())
        });
    }
}

#[cfg(not(target_os = "linux"))]
fn die_with_parent(_command: &mut Command) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_robots_map_to_the_guest_host() {
        assert_eq!(
            guest_robot("127.0.0.1:30000"),
            Ok("10.0.2.2:30000".parse().unwrap())
        );
        assert_eq!(
            guest_robot("localhost:4242"),
            Ok("10.0.2.2:4242".parse().unwrap())
        );
    }

    #[test]
    fn other_robots_are_refused() {
        for robot in [
            "192.168.1.106:30000",
            "127.0.0.2:30000",
            "[::1]:30000",
            "0.0.0.0:30000",
            "10.0.2.2:30000",
            "127.0.0.1",
            "localhost",
            "localhost:http",
            "robot.local:30000",
            "127.0.0.1:0",
        ] {
            let err = guest_robot(robot).unwrap_err();
            assert!(err.contains("127.0.0.1:PORT"), "{robot}: {err}");
            assert!(err.starts_with(&format!("--robot {robot}:")), "{err}");
        }
    }

    #[test]
    fn command_line() {
        let args = args(
            Path::new("/fw/x30-panel"),
            "10.0.2.2:30001".parse().unwrap(),
            Path::new("/run/settings.bin"),
            Path::new("/tmp/x30-qemu-1/console.sock"),
            None,
            &["-d".into(), "guest_errors".into()],
        );
        let args: Vec<&str> = args.iter().map(|a| a.to_str().unwrap()).collect();
        assert_eq!(
            args.join(" "),
            "-M mps2-an386 -nographic -monitor none \
             -chardev socket,id=console,path=/tmp/x30-qemu-1/console.sock \
             -serial stdio -serial chardev:console -semihosting-config \
             enable=on,target=native,arg=x30-panel,arg=10.0.2.2:30001,arg=settings=/run/settings.bin \
             -nic user,model=lan9118 -kernel /fw/x30-panel -d guest_errors"
        );
    }

    #[test]
    fn the_web_page_is_forwarded_from_a_loopback_port_of_the_host() {
        assert_eq!(http_port("127.0.0.1:8080"), Ok(8080));
        assert_eq!(http_port("localhost:18080"), Ok(18080));
        let args = args(
            Path::new("/fw/x30-panel"),
            "10.0.2.2:30001".parse().unwrap(),
            Path::new("/run/settings.bin"),
            Path::new("/run/console.sock"),
            Some(8080),
            &[],
        );
        let args: Vec<&str> = args.iter().map(|a| a.to_str().unwrap()).collect();
        let nic = args.iter().position(|&a| a == "-nic").expect("-nic");
        assert_eq!(
            args[nic + 1],
            "user,model=lan9118,hostfwd=tcp:127.0.0.1:8080-:80"
        );
    }

    #[test]
    fn web_page_ports_off_loopback_are_refused() {
        for http in [
            "0.0.0.0:8080",
            "192.168.1.10:8080",
            "127.0.0.2:8080",
            "[::1]:8080",
            "8080",
            "localhost",
            "127.0.0.1:0",
            "127.0.0.1:http",
        ] {
            let err = http_port(http).unwrap_err();
            assert!(err.starts_with(&format!("--http {http}:")), "{err}");
            assert!(err.contains("127.0.0.1:PORT"), "{http}: {err}");
        }
    }

    #[test]
    fn commas_in_paths_are_doubled_for_qemu() {
        let args = args(
            Path::new("/fw/x30-panel"),
            "10.0.2.2:30001".parse().unwrap(),
            Path::new("/a,b/settings.bin"),
            Path::new("/t,mp/console.sock"),
            None,
            &[],
        );
        let args: Vec<&str> = args.iter().map(|a| a.to_str().unwrap()).collect();
        assert!(args.contains(&"socket,id=console,path=/t,,mp/console.sock"));
        assert!(
            args.iter()
                .any(|a| a.ends_with(",arg=settings=/a,,b/settings.bin"))
        );
    }

    /// A fresh folder for one test.
    fn folder() -> tempfile::TempDir {
        tempfile::Builder::new()
            .prefix("x30-qemu-test-")
            .tempdir()
            .unwrap()
    }

    #[test]
    fn the_default_settings_file_is_a_fresh_empty_one_in_the_folder() {
        let dir = folder();
        let path = settings_file(None, dir.path()).unwrap();
        assert!(path.is_absolute());
        assert_eq!(path, dir.path().join("settings.bin"));
        assert_eq!(fs::metadata(&path).unwrap().len(), 0);
    }

    #[test]
    fn a_named_settings_file_is_created_if_missing_and_kept_if_not() {
        let dir = folder();
        let named = dir.path().join("saved.bin");
        let path = settings_file(Some(&named), Path::new("/nonexistent")).unwrap();
        assert_eq!(path, named);
        assert_eq!(fs::metadata(&path).unwrap().len(), 0);
        fs::write(&path, [0x12u8; 100]).unwrap();
        settings_file(Some(&named), Path::new("/nonexistent")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), [0x12u8; 100]);
    }

    #[test]
    fn unusable_settings_paths_are_refused() {
        let dir = folder();
        let spaced = dir.path().join("my settings.bin");
        let err = settings_file(Some(&spaced), dir.path()).unwrap_err();
        assert!(err.contains("whitespace"), "{err}");
        let long = dir.path().join("s".repeat(250));
        let err = settings_file(Some(&long), dir.path()).unwrap_err();
        assert!(err.contains("longer than 255 bytes"), "{err}");
        // Refused before anything was created.
        assert!(!spaced.exists() && !long.exists());
        let relative = settings_file(Some(Path::new("x30-qemu-no-such-dir/s.bin")), dir.path());
        assert!(relative.unwrap_err().contains("cannot open or create it"));
        let missing = Path::new("/nonexistent/settings.bin");
        let err = settings_file(Some(missing), dir.path()).unwrap_err();
        assert!(
            err.starts_with("--settings /nonexistent/settings.bin: cannot open or create it"),
            "{err}"
        );
    }

    #[test]
    fn finding_programs() {
        assert_eq!(find(Path::new("sh")).map(|p| p.is_file()), Some(true));
        assert_eq!(find(Path::new("/bin/sh")), Some(PathBuf::from("/bin/sh")));
        assert_eq!(find(Path::new("x30-no-such-program")), None);
        assert_eq!(find(Path::new("/nonexistent/qemu")), None);
        // A file that is not executable is not a program.
        assert_eq!(
            find(Path::new(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/Cargo.toml"
            ))),
            None
        );
    }
}
