//! `x30-sim`: runs the robot_server simulator until interrupted.
//!
//! Prints `x30-sim listening on ADDR` once it listens, so that scripts can start it on
//! port 0 and read the port it got.

use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, ValueEnum};
use x30_sim::{Config, DEFAULT_LISTEN, Declaration, Faults, Simulator};

/// A simulator of the DEEP Robotics Jueying X30 robot_server (protocol V1.0.12).
#[derive(Debug, Parser)]
#[command(name = "x30-sim", version, about)]
struct Cli {
    /// Address to listen on (port 0 picks a free port).
    #[arg(long, value_name = "ADDR", default_value_t = DEFAULT_LISTEN)]
    listen: SocketAddr,
    /// How many times faster than real time the robot's time runs.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0, value_parser = positive_float)]
    time_scale: f64,
    /// Delay every answer by this many milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 0)]
    delay_ms: u64,
    /// Delay answers of Type TYPE by MS more milliseconds, without holding up other answers
    /// (repeatable: --delay-type 1002=1200 --delay-type 2001=300).
    #[arg(long = "delay-type", value_name = "TYPE=MS", value_parser = type_delay)]
    delay_types: Vec<(i32, Duration)>,
    /// Answer nothing on a connection for its first MS milliseconds; answers due sooner
    /// wait until then (a robot slow to set up each new client).
    #[arg(long, value_name = "MS", default_value_t = 0)]
    warm_up_ms: u64,
    /// Read and log requests but neither act on them nor answer (a half-open robot).
    #[arg(long)]
    mute: bool,
    /// Refuse connections (accept and close them at once) for MS milliseconds from the start.
    #[arg(long, value_name = "MS")]
    refuse_for_ms: Option<u64>,
    /// MS milliseconds from the start, stop reading every connection then open, leaving it
    /// open (client handlers that hung); connections made later are served.
    #[arg(long, value_name = "MS")]
    hang_after_ms: Option<u64>,
    /// Serve one connection at a time: while one is open, new ones wait in the backlog,
    /// connected but unread (a single-threaded robot_server).
    #[arg(long)]
    one_at_a_time: bool,
    /// Keep at most N connections open: one made while N are open is closed at once,
    /// unread (a robot_server that takes a limited number of clients).
    #[arg(long, value_name = "N")]
    max_connections: Option<usize>,
    /// Keep only the newest connection: each new one closes the others (a robot_server
    /// that serves one client and lets a new one replace it).
    #[arg(long)]
    newest_only: bool,
    /// Refuse the next N soft emergency stops (Command 13): ErrorCode 1, no state change.
    #[arg(long, value_name = "N", default_value_t = 0)]
    refuse_estops: u32,
    /// Close each connection on receiving its Nth frame, without answering it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    drop_after: Option<u64>,
    /// Close each connection once it has written an answer (a robot_server that serves one
    /// request a connection).
    #[arg(long)]
    hang_up_after_answer: bool,
    /// Close a connection, without answering, when it receives a request of this Type
    /// (repeatable).
    #[arg(long = "hang-up-on", value_name = "TYPE")]
    hang_up_on: Vec<i32>,
    /// Send a few garbage bytes (no sync sequence) before each answer frame.
    #[arg(long)]
    garbage: bool,
    /// Between answers, stream garbage bytes (no sync sequence) as fast as the client reads
    /// them; answers still go out whole.
    #[arg(long)]
    flood: bool,
    /// Send a frame with an empty body, with the answer's message ID, before each answer
    /// frame (a keep-alive that shares the ID).
    #[arg(long)]
    empty_frames: bool,
    /// Fill the 8 reserved bytes of each answer's header (zeros in the document) with
    /// non-zero bytes.
    #[arg(long)]
    reserved_bytes: bool,
    /// Write each answer in chunks of N bytes, about 1 ms apart.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    split: Option<u64>,
    /// Write each answer together with an extra 1002 status frame (ID + 0x8000) in one write.
    #[arg(long)]
    merge: bool,
    /// Put before each answer frame a copy of it cut short (the header declares the whole
    /// body, half of it follows), as a robot whose write went out only in part.
    #[arg(long)]
    cut_frames: bool,
    /// Answer with Type 2102 instead of the real Type.
    #[arg(long)]
    unknown_type: bool,
    /// Name Command N in every motion answer (Type 2) instead of the request's, as a robot
    /// that fills its answers in from one template.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    motion_answer_command: Option<i32>,
    /// Insert undocumented items (AngleYaw, CurRuntime, RTKState, …) into every answer.
    #[arg(long)]
    unknown_items: bool,
    /// Report the pose as unknown: `nan` for PosX, PosY, PosZ, Roll, Pitch and Yaw in status
    /// answers.
    #[arg(long)]
    unknown_pose: bool,
    /// Leave every item but MotionState out of status answers.
    #[arg(long)]
    sparse_status: bool,
    /// Leave the item NAME out of every answer (repeatable, or names separated by commas):
    /// a robot that lacks that reading. A name no answer has is refused.
    #[arg(long, value_name = "NAME", value_delimiter = ',', value_parser = answer_item)]
    leave_out: Vec<String>,
    /// Write floats in answers with a decimal comma (`12,345678`), as a robot under a
    /// locale such as de_DE would.
    #[arg(long)]
    decimal_comma: bool,
    /// XML declaration of answers.
    #[arg(long, value_enum, default_value_t = DeclarationArg::Double)]
    declaration: DeclarationArg,
    /// Write every received frame to FILE as JSON lines, with the progress of navigation
    /// tasks (each waypoint set out for, how each task ended).
    #[arg(long, value_name = "FILE")]
    log: Option<PathBuf>,
    /// Make waypoints with this Value unreachable: a navigation task fails with ErrorStatus
    /// 41804 (global path planning failed) when it sets out for one (repeatable).
    #[arg(
        long = "unreachable",
        value_name = "VALUE",
        allow_negative_numbers = true
    )]
    unreachable: Vec<i32>,
}

/// `--declaration` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DeclarationArg {
    /// `<?xml version="1.0" encoding="UTF-8"?>`
    Double,
    /// `<?xml version='1.0' encoding='utf-8'?>`
    Single,
    /// No declaration.
    None,
}

impl From<DeclarationArg> for Declaration {
    fn from(arg: DeclarationArg) -> Self {
        match arg {
            DeclarationArg::Double => Self::Double,
            DeclarationArg::Single => Self::Single,
            DeclarationArg::None => Self::None,
        }
    }
}

/// Parses `TYPE=MS`, for `--delay-type`.
fn type_delay(text: &str) -> Result<(i32, Duration), String> {
    let (message_type, ms) = text
        .split_once('=')
        .ok_or_else(|| format!("{text:?} is not TYPE=MS"))?;
    let message_type = message_type
        .trim()
        .parse::<i32>()
        .map_err(|e| format!("Type {message_type:?}: {e}"))?;
    let ms = ms
        .trim()
        .parse::<u64>()
        .map_err(|e| format!("milliseconds {ms:?}: {e}"))?;
    Ok((message_type, Duration::from_millis(ms)))
}

/// An item name some answer has, for `--leave-out`: a misspelt one would leave nothing out.
fn answer_item(text: &str) -> Result<String, String> {
    let names = x30_sim::faults::answer_item_names();
    if names.contains(text) {
        return Ok(text.to_owned());
    }
    let known: Vec<&str> = names.iter().map(String::as_str).collect();
    Err(format!(
        "no answer has an item {text:?}; the answers' items: {}",
        known.join(", ")
    ))
}

fn positive_float(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("{text:?} is not a positive number")),
    }
}

impl Cli {
    fn config(&self) -> Config {
        Config {
            listen: self.listen,
            time_scale: self.time_scale,
            faults: Faults {
                delay: Duration::from_millis(self.delay_ms),
                type_delays: self.delay_types.clone(),
                one_at_a_time: self.one_at_a_time,
                max_connections: self.max_connections,
                newest_only: self.newest_only,
                warm_up: Duration::from_millis(self.warm_up_ms),
                mute: self.mute,
                refuse_connections_until: self
                    .refuse_for_ms
                    .map(|ms| x30_sim::faults::after(Instant::now(), Duration::from_millis(ms))),
                hang_at: self
                    .hang_after_ms
                    .map(|ms| x30_sim::faults::after(Instant::now(), Duration::from_millis(ms))),
                refuse_estops: self.refuse_estops,
                drop_after: self.drop_after,
                hang_up_after_answer: self.hang_up_after_answer,
                hang_up_on: self.hang_up_on.clone(),
                garbage: self.garbage,
                flood: self.flood,
                empty_frames: self.empty_frames,
                reserved_bytes: self.reserved_bytes,
                split: self.split.and_then(|n| usize::try_from(n).ok()),
                merge: self.merge,
                cut_frames: self.cut_frames,
                unknown_type: self.unknown_type,
                motion_answer_command: self.motion_answer_command,
                unknown_items: self.unknown_items,
                unknown_pose: self.unknown_pose,
                sparse_status: self.sparse_status,
                leave_out: self.leave_out.clone(),
                decimal_comma: self.decimal_comma,
                declaration: self.declaration.into(),
            },
            log_file: self.log.clone(),
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let sim = match Simulator::start(cli.config()) {
        Ok(sim) => sim,
        Err(e) => {
            eprintln!("x30-sim: cannot start on {}: {e}", cli.listen);
            return ExitCode::FAILURE;
        }
    };
    sim.robot(|r| r.set_unreachable_points(&cli.unreachable));
    println!("x30-sim listening on {}", sim.addr());
    // Scripts wait for this line; make sure it leaves even when stdout is a pipe.
    let _ = std::io::stdout().flush();
    // Serve until the process is interrupted; the threads do the work.
    loop {
        std::thread::park();
    }
}
