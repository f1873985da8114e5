//! On-target smoke test of the QEMU mps2-an386 board, run in QEMU by `scripts/qemu-test.sh`.
//!
//! It checks, on the emulated Cortex-M4F with the board's own drivers:
//!
//! 1. the codec: a request encoded into a frame and decoded again is the same request;
//! 2. the time driver: the clock advances, and a 100 ms timer (the alarm path) takes 100 ms;
//! 3. the virtual panel's line parser;
//! 4. the semihosting command line: the runner's robot address is found;
//! 5. the LAN9118 driver under embassy-net: DHCP from QEMU's user network gives 10.0.2.15.
//!
//! Each check prints `ok NAME` or `FAILED NAME: why`; QEMU exits with status 0 when all
//! passed, 1 otherwise (and on a panic or hard fault).
#![no_std]
#![no_main]

// The firmware's board support, compiled into this test image as it is into the firmware.
#[allow(dead_code, unused_imports)]
#[path = "../src/board/mod.rs"]
mod board;

use board::qemu_mps2_an386::lan9118::Lan9118;
use board::qemu_mps2_an386::{MAC, arguments, semihosting};
use embassy_executor::Spawner;
use embassy_net::{Ipv4Address, Ipv4Cidr, Runner, StackResources};
use embassy_time::{Duration, Instant, Timer, with_timeout};
use log::LevelFilter;
use static_cell::StaticCell;
use x30_panel::client::ClientError;
use x30_panel::config::DEFAULT_LIGHTS;
use x30_panel::panel::virtual_panel::LineReader;
use x30_panel::panel::{Button, ButtonEvent};
use x30_panel::proto::frame::{self, FrameDecoder};
use x30_panel::proto::message::Request;
use x30_panel::proto::time::Timestamp;

/// Prints the outcome of one check; returns whether it passed.
fn report(name: &str, outcome: Result<(), &str>) -> bool {
    match outcome {
        Ok(()) => semihosting::print_line(format_args!("ok {name}")),
        Err(why) => semihosting::print_line(format_args!("FAILED {name}: {why}")),
    }
    outcome.is_ok()
}

/// A light request survives frame and XML encoding and decoding.
fn codec_round_trip() -> Result<(), &'static str> {
    let request = Request::Light(DEFAULT_LIGHTS[3]);
    let time = Timestamp::DOCUMENT_EPOCH;
    let mut out = [0u8; 512];
    let len = frame::encode_with(&mut out, 7, |body| {
        request.encode(&time, body).map_err(ClientError::Encode)
    })
    .map_err(|_| "encoding failed")?;
    let mut decoder = FrameDecoder::<512>::new();
    let spare = decoder.spare();
    let bytes = out.get(..len).ok_or("frame longer than its buffer")?;
    spare
        .get_mut(..len)
        .ok_or("decoder buffer too small")?
        .copy_from_slice(bytes);
    decoder.commit(len);
    let frame = decoder
        .decode()
        .ok_or("no frame decoded")?
        .map_err(|_| "frame error")?;
    if frame.message_id != 7 {
        return Err("wrong message ID");
    }
    let decoded = Request::decode(frame.asdu).map_err(|_| "XML decoding failed")?;
    if decoded.message != request || decoded.time != time {
        return Err("decoded request differs");
    }
    Ok(())
}

/// The clock advances by itself, and a timer wakes on time.
async fn time_driver() -> Result<(), &'static str> {
    let start = Instant::now();
    // Busy for a while: the counter must move without any timer pending.
    let mut spins = 0u32;
    while Instant::now() == start {
        spins += 1;
        if spins > 10_000_000 {
            return Err("Instant::now() does not advance");
        }
    }
    let before = Instant::now();
    Timer::after(Duration::from_millis(100)).await;
    let slept = before.elapsed().as_millis();
    if !(100..=300).contains(&slept) {
        semihosting::print_line(format_args!("  a 100 ms timer took {slept} ms"));
        return Err("timer duration out of range");
    }
    // A timeout fires through the same alarm while another future stays pending.
    if with_timeout(Duration::from_millis(20), core::future::pending::<()>())
        .await
        .is_ok()
    {
        return Err("timeout did not fire");
    }
    Ok(())
}

/// The virtual panel's lines become button events; bad lines are errors.
fn virtual_panel() -> Result<(), &'static str> {
    let mut reader = LineReader::new();
    let at = Instant::from_millis(7);
    let mut events = [None, None];
    for (slot, line) in events
        .iter_mut()
        .zip([&b"+turn-left\r"[..], b"-turn-left\n"])
    {
        for &byte in line {
            if let Some(result) = reader.push(byte, at) {
                *slot = result.map_err(|_| "valid line rejected")?;
            }
        }
    }
    let expected = |pressed| {
        Some(ButtonEvent {
            button: Button::TurnLeft,
            pressed,
            at,
        })
    };
    if events != [expected(true), expected(false)] {
        return Err("wrong events");
    }
    let bad = b"+jump\n".iter().find_map(|&byte| reader.push(byte, at));
    if !matches!(bad, Some(Err(_))) {
        return Err("unknown button accepted");
    }
    Ok(())
}

/// The runner passes a robot address on the semihosting command line.
fn command_line() -> Result<(), &'static str> {
    let mut buf = [0u8; 256];
    let line = semihosting::command_line(&mut buf).ok_or("no command line")?;
    semihosting::print_line(format_args!("  command line: {line}"));
    arguments(line)
        .robot
        .ok_or("no robot address on the command line")?;
    Ok(())
}

/// The network stack's memory.
static RESOURCES: StaticCell<StackResources<2>> = StaticCell::new();

/// Runs the network stack.
#[embassy_executor::task]
async fn network_task(mut runner: Runner<'static, Lan9118>) -> ! {
    runner.run().await
}

/// The LAN9118 comes up and DHCP gives the address QEMU's user network hands out.
async fn network(spawner: Spawner) -> Result<(), &'static str> {
    let driver = Lan9118::new(MAC).map_err(|_| "LAN9118 not found or not responding")?;
    let config = embassy_net::Config::dhcpv4(Default::default());
    let (stack, runner) =
        embassy_net::new(driver, config, RESOURCES.init(StackResources::new()), 1);
    spawner.spawn(network_task(runner).map_err(|_| "cannot spawn the network task")?);
    with_timeout(Duration::from_secs(15), stack.wait_config_up())
        .await
        .map_err(|_| "no DHCP lease in 15 s")?;
    let address = stack.config_v4().ok_or("no IPv4 configuration")?.address;
    semihosting::print_line(format_args!("  address: {address}"));
    if address != Ipv4Cidr::new(Ipv4Address::new(10, 0, 2, 15), 24) {
        return Err("not QEMU's 10.0.2.15/24");
    }
    Ok(())
}

/// Starts the board's executor with the checks, after reset.
#[cortex_m_rt::entry]
fn entry() -> ! {
    board::start(|spawner| spawner.spawn(main(spawner).expect("the checks are spawned once")))
}

/// Runs every check, then ends QEMU with their verdict.
#[embassy_executor::task]
async fn main(spawner: Spawner) -> ! {
    semihosting::init_logging(LevelFilter::Warn);
    let results = [
        report("codec round trip", codec_round_trip()),
        report("time driver", time_driver().await),
        report("virtual panel lines", virtual_panel()),
        report("semihosting command line", command_line()),
        report("LAN9118 and DHCP", network(spawner).await),
    ];
    let passed = results.iter().filter(|&&ok| ok).count();
    let failed = results.len() - passed;
    semihosting::print_line(format_args!("{passed} passed, {failed} failed"));
    semihosting::exit(failed == 0)
}
