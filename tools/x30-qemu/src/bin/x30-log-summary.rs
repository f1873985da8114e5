//! `x30-log-summary`: what a robot received, from x30-sim's request log (`--log FILE`, JSON
//! lines): requests counted per Type and Command, the rate of each run of repeated motion
//! commands, and checks that exit non-zero when they fail. The demo (scripts/demo.sh)
//! prints its session's summary with it.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use serde_json::Value;
use x30_panel::proto::codes::{MessageType, MotionCommandCode};

/// Motion repeats must come at 3–5 Hz: the robot stops without them (docs/protocol.md,
/// "Type 2: motion control").
const RATE_RANGE: (f64, f64) = (3.0, 5.0);

/// A gap longer than this ends a run of repeats: the button was released and pressed again.
const RUN_GAP: f64 = 1.0;

/// Summarises an x30-sim request log and checks it.
#[derive(Debug, Parser)]
#[command(name = "x30-log-summary", version, about)]
struct Cli {
    /// The request log x30-sim wrote with --log.
    log: PathBuf,
    /// Fail unless this request was received: a Type, or 2/COMMAND for a motion command,
    /// such as 1003 or 2/13 (repeat for several).
    #[arg(long, value_name = "TYPE|2/COMMAND", value_parser = parse_expect)]
    expect: Vec<(i64, Option<i64>)>,
}

fn parse_expect(text: &str) -> Result<(i64, Option<i64>), String> {
    let number = |t: &str| {
        t.parse::<i64>()
            .map_err(|_| format!("{text:?} is not TYPE or 2/COMMAND"))
    };
    match text.split_once('/') {
        Some((ty, command)) => Ok((number(ty)?, Some(number(command)?))),
        None => Ok((number(text)?, None)),
    }
}

/// One logged request, as far as the summary cares.
#[derive(Debug, Clone, PartialEq)]
struct Entry {
    t: f64,
    conn: i64,
    message_type: Option<i64>,
    command: Option<i64>,
    error: Option<String>,
}

impl Entry {
    /// The request a log line records; `None` for a navigation task's progress line
    /// (`"event"`), which is not a request.
    fn from_json(line: &str) -> Result<Option<Self>, String> {
        let v: Value = serde_json::from_str(line).map_err(|e| format!("not JSON ({e})"))?;
        if v.get("event").is_some() {
            return Ok(None);
        }
        Ok(Some(Self {
            t: v["t"].as_f64().ok_or("no time `t`")?,
            conn: v["conn"].as_i64().unwrap_or(0),
            message_type: v["type"].as_i64(),
            command: v["command"].as_i64(),
            error: v["error"].as_str().map(str::to_owned),
        }))
    }
}

/// The name of a Type, or of a Type 2 Command.
fn name(message_type: i64, command: Option<i64>) -> String {
    let Ok(raw) = i32::try_from(message_type) else {
        return "unknown".into();
    };
    match (
        MessageType::from_raw(raw),
        command.and_then(|c| i32::try_from(c).ok()),
    ) {
        (MessageType::Motion, Some(c)) => MotionCommandCode::from_raw(c).description().into(),
        (ty, _) => ty.description().into(),
    }
}

/// A run of one repeated motion command: how many, from when to when.
#[derive(Debug, Clone, PartialEq)]
struct Run {
    command: i64,
    count: usize,
    first: f64,
    last: f64,
}

impl Run {
    /// Repeats per second; `None` for a run too short to have a rate.
    fn rate(&self) -> Option<f64> {
        (self.count >= 3 && self.last > self.first)
            .then(|| (self.count - 1) as f64 / (self.last - self.first))
    }
}

/// Runs of repeated translation and rotation commands (1–4, 11, 12): consecutive Type 2
/// requests with the same Command, no gap longer than [`RUN_GAP`].
fn motion_runs(entries: &[Entry]) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    let motions = entries
        .iter()
        .filter(|e| e.message_type == Some(2))
        .filter_map(|e| Some((e.t, e.command?)));
    for (t, command) in motions {
        match runs.last_mut() {
            Some(run) if run.command == command && t - run.last <= RUN_GAP => {
                run.count += 1;
                run.last = t;
            }
            _ => runs.push(Run {
                command,
                count: 1,
                first: t,
                last: t,
            }),
        }
    }
    runs.retain(|r| matches!(r.command, 1..=4 | 11 | 12));
    runs
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let text = match std::fs::read_to_string(&cli.log) {
        Ok(text) => text,
        Err(e) => {
            eprintln!("x30-log-summary: cannot read {}: {e}", cli.log.display());
            return ExitCode::from(2);
        }
    };
    let mut entries = Vec::new();
    for (n, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        match Entry::from_json(line) {
            Ok(entry) => entries.extend(entry),
            Err(e) => {
                eprintln!("x30-log-summary: {}:{}: {e}", cli.log.display(), n + 1);
                return ExitCode::from(2);
            }
        }
    }
    let failures = summarise(&entries, &cli.expect);
    if failures == 0 {
        println!("all checks passed");
        ExitCode::SUCCESS
    } else {
        println!("{failures} check(s) failed");
        ExitCode::FAILURE
    }
}

/// Prints the summary and the checks; returns how many checks failed.
fn summarise(entries: &[Entry], expect: &[(i64, Option<i64>)]) -> usize {
    let mut connections: Vec<i64> = entries.iter().map(|e| e.conn).collect();
    connections.sort_unstable();
    connections.dedup();
    let span = entries.last().map_or(0.0, |e| e.t) - entries.first().map_or(0.0, |e| e.t);
    println!(
        "{} requests on {} connection(s) over {span:.1} s",
        entries.len(),
        connections.len()
    );

    let mut counts: BTreeMap<(i64, Option<i64>), usize> = BTreeMap::new();
    for e in entries.iter().filter(|e| e.error.is_none()) {
        if let Some(ty) = e.message_type {
            // Only Type 2's Command says what it is; other Types have Command 1 throughout.
            let command = if ty == 2 { e.command } else { None };
            *counts.entry((ty, command)).or_default() += 1;
        }
    }
    for ((ty, command), count) in &counts {
        let key = match command {
            Some(c) => format!("{ty}/{c}"),
            None => ty.to_string(),
        };
        println!("  {key:>8}  {:<36} {count:>5}", name(*ty, *command));
    }

    let mut failures = 0;
    let mut check = |ok: bool, what: String| {
        println!("{} {what}", if ok { "ok  " } else { "FAIL" });
        failures += usize::from(!ok);
    };
    for run in motion_runs(entries) {
        let what = format!(
            "{} ({}) x{} from {:.2} s to {:.2} s",
            name(2, Some(run.command)),
            run.command,
            run.count,
            run.first,
            run.last
        );
        match run.rate() {
            Some(rate) => check(
                (RATE_RANGE.0..=RATE_RANGE.1).contains(&rate),
                format!(
                    "{what}: {rate:.2} Hz (needed: {}–{} Hz)",
                    RATE_RANGE.0, RATE_RANGE.1
                ),
            ),
            None => println!("     {what}: too short for a rate"),
        }
    }
    let garbled = entries.iter().filter(|e| e.error.is_some()).count();
    check(garbled == 0, format!("{garbled} undecodable frame(s)"));
    for &(ty, command) in expect {
        let n = counts
            .iter()
            .filter(|((t, c), _)| *t == ty && (command.is_none() || *c == command))
            .map(|(_, n)| n)
            .sum::<usize>();
        let key = match command {
            Some(c) => format!("{ty}/{c}"),
            None => ty.to_string(),
        };
        check(
            n > 0,
            format!("{key} {} received {n} time(s)", name(ty, command)),
        );
    }
    failures
}

#[cfg(test)]
mod tests {
    use super::*;

    fn motion(t: f64, command: i64) -> Entry {
        Entry {
            t,
            conn: 1,
            message_type: Some(2),
            command: Some(command),
            error: None,
        }
    }

    #[test]
    fn entries_from_the_simulators_log() {
        let e = Entry::from_json(
            r#"{"t":1.204,"conn":1,"id":3,"type":2,"command":1,"items":{"Value":-1.0}}"#,
        )
        .unwrap();
        assert_eq!(e, Some(motion(1.204, 1)));
        let bad = Entry::from_json(
            r#"{"t":0.25,"conn":3,"id":null,"type":null,"command":null,"error":"frame: Garbage"}"#,
        )
        .unwrap()
        .unwrap();
        assert_eq!(bad.message_type, None);
        assert_eq!(bad.error.as_deref(), Some("frame: Garbage"));
        // A task's progress is not a request.
        let progress = r#"{"t":2.5,"event":"waypoint","index":1,"of":3,"value":2}"#;
        assert_eq!(Entry::from_json(progress), Ok(None));
        assert!(Entry::from_json("{}").is_err());
        assert!(Entry::from_json("nope").is_err());
    }

    #[test]
    fn runs_split_on_other_commands_and_gaps() {
        let mut log: Vec<Entry> = (0..9)
            .map(|i| motion(1.0 + 0.25 * f64::from(i), 1))
            .collect();
        log.push(motion(3.1, 6));
        log.push(motion(4.0, 1));
        log.push(motion(4.25, 1));
        log.push(motion(6.0, 1));
        let runs = motion_runs(&log);
        assert_eq!(runs.len(), 3, "{runs:?}");
        assert_eq!(runs[0].count, 9);
        assert_eq!(runs[0].rate(), Some(4.0));
        assert_eq!(runs[1].count, 2);
        assert_eq!(runs[1].rate(), None);
        assert_eq!(runs[2].count, 1);
    }

    #[test]
    fn names_and_expectations() {
        assert_eq!(name(2, Some(13)), "soft emergency stop");
        assert_eq!(name(1003, None), "navigation task");
        assert_eq!(parse_expect("2/13"), Ok((2, Some(13))));
        assert_eq!(parse_expect("1004"), Ok((1004, None)));
        assert!(parse_expect("2/x").is_err());
    }

    #[test]
    fn checks_count_failures() {
        let log: Vec<Entry> = (0..9).map(|i| motion(0.25 * f64::from(i), 1)).collect();
        assert_eq!(summarise(&log, &[(2, Some(1))]), 0);
        assert_eq!(summarise(&log, &[(2, Some(6)), (1003, None)]), 2);
        // 10 Hz is too fast.
        let fast: Vec<Entry> = (0..9).map(|i| motion(0.1 * f64::from(i), 1)).collect();
        assert_eq!(summarise(&fast, &[]), 1);
    }
}
