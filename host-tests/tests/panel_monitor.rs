//! The poll schedule and the robot view (docs/design.md, "Monitor").

mod panel_support;

use std::collections::BTreeMap;

use embassy_time::{Duration, Instant};
use panel_support::*;
use x30_panel::config::Config;
use x30_panel::panel::ConnectionState;
use x30_panel::panel::{Monitor, RobotView};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;

/// Runs the monitor from `from` until just before `to`, as the application does, and returns
/// when each Type was polled.
fn polls(
    monitor: &mut Monitor,
    from: Instant,
    to: Instant,
    mut event: impl FnMut(&mut Monitor, Instant),
) -> BTreeMap<i32, Vec<u64>> {
    let mut out = BTreeMap::<i32, Vec<u64>>::new();
    let mut now = from;
    while now < to {
        event(monitor, now);
        while let Some(request) = monitor.next_poll(now) {
            out.entry(request.message_type().raw())
                .or_default()
                .push(now.as_millis());
        }
        // Wake at the next poll, or at the next whole 100 ms for the test's events.
        let tick = Instant::from_millis((now.as_millis() / 100 + 1) * 100);
        now = monitor
            .next_deadline()
            .map_or(tick, |d| d.min(tick))
            .max(now);
    }
    out
}

fn counts(polls: &BTreeMap<i32, Vec<u64>>) -> Vec<(i32, usize)> {
    polls.iter().map(|(t, v)| (*t, v.len())).collect()
}

/// Every poll but the navigation status, in the order they go out when due together.
const EVERY_POLL: [Request; 4] = [
    Request::Status,
    Request::Perception,
    Request::Battery,
    Request::MotorTemperatures,
];

/// Every poll due at `now`, in the order they go out.
fn due(m: &mut Monitor, now: Instant) -> Vec<Request> {
    std::iter::from_fn(|| m.next_poll(now)).collect()
}

/// A 1008 answer with every motor at `celsius`.
fn motors_at(celsius: f32) -> MotorTemperatures {
    MotorTemperatures {
        left_front_sway: celsius,
        left_front_hip: celsius,
        left_front_knee: celsius,
        right_front_sway: celsius,
        right_front_hip: celsius,
        right_front_knee: celsius,
        left_back_sway: celsius,
        left_back_hip: celsius,
        left_back_knee: celsius,
        right_back_sway: celsius,
        right_back_hip: celsius,
        right_back_knee: celsius,
    }
}

#[test]
fn one_minute_of_polls() {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(0));
    let p = polls(&mut m, at(0), at(60_000), |_, _| {});
    assert_eq!(
        counts(&p),
        [(1002, 120), (1008, 6), (2001, 12), (2002, 120)],
        "1007 only while a task runs"
    );
    let spaced = |t: i32, ms: u64| p[&t].windows(2).all(|w| w[1] - w[0] == ms);
    assert!(spaced(1002, 500) && spaced(2002, 500));
    assert!(spaced(2001, 5000) && spaced(1008, 10_000));
}

#[test]
fn nav_status_polled_at_1_hz_only_while_a_task_runs() {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(0));
    let p = polls(&mut m, at(0), at(60_000), |m, now| match now.as_millis() {
        10_000 => m.navigation(true, now),
        30_500 => m.navigation(false, now),
        _ => {}
    });
    let nav = &p[&1007];
    // From one second after the task started until it ended.
    assert_eq!(nav.first(), Some(&11_000));
    assert_eq!(nav.last(), Some(&30_000));
    assert_eq!(nav.len(), 20);
    assert!(nav.windows(2).all(|w| w[1] - w[0] == 1000));
}

#[test]
fn nothing_is_polled_while_disconnected() {
    let mut m = Monitor::new(&Config::default());
    assert_eq!(m.next_deadline(), None);
    assert_eq!(m.next_poll(at(10_000)), None);
    m.navigation(true, at(0));
    assert_eq!(m.next_deadline(), None);
    // Connecting while a task runs starts its 1007 polls too, a period later.
    m.connection(ConnectionState::Open, at(20_000));
    let polls = due(&mut m, at(21_000));
    assert!(polls.contains(&Request::NavStatus), "{polls:?}");
    m.connection(ConnectionState::Connecting, at(25_000));
    assert_eq!(m.next_deadline(), None);
    assert_eq!(m.next_poll(at(30_000)), None);
}

#[test]
fn connecting_polls_everything_at_once_in_order() {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(1000));
    assert_eq!(m.next_deadline(), Some(at(1000)));
    assert_eq!(due(&mut m, at(1000)), EVERY_POLL);
    assert_eq!(m.next_deadline(), Some(at(1500)));
    // A second "connected" report does not restart the schedule.
    m.connection(ConnectionState::Open, at(1200));
    assert_eq!(m.next_poll(at(1200)), None);
}

#[test]
fn a_robot_that_hangs_up_after_each_answer_is_asked_every_poll_in_turn_and_a_new_robot_everything()
{
    let mut m = Monitor::new(&Config::default());
    // Each connection gets one poll answered, then is lost and reopened 10 ms later.
    let mut first_polls = Vec::new();
    for n in 0..5 {
        let now = at(n * 20);
        m.connection(ConnectionState::Open, now);
        first_polls.extend(m.next_poll(now));
        m.connection(ConnectionState::Connecting, now + Duration::from_millis(10));
    }
    assert_eq!(first_polls, EVERY_POLL, "then nothing is due until 500 ms");
    // A connection to another robot asks it everything at once.
    m.robot_moved();
    m.connection(ConnectionState::Open, at(200));
    assert_eq!(due(&mut m, at(200)), EVERY_POLL);
    m.connection(ConnectionState::Connecting, at(210));
    // A reconnection after a long outage asks everything at once, the most overdue first.
    m.connection(ConnectionState::Open, at(20_000));
    assert_eq!(due(&mut m, at(20_000)), EVERY_POLL);
}

#[test]
fn a_poll_lost_with_its_connection_goes_first_on_the_next() {
    let mut m = Monitor::new(&Config::default());
    // Each connection gets one poll answered; the next one due, if any, is written, and the
    // robot hangs up before answering it.
    let mut answered = Vec::new();
    for n in 0..4 {
        let now = at(n * 20);
        m.connection(ConnectionState::Open, now);
        answered.extend(m.next_poll(now));
        if let Some(lost) = m.next_poll(now) {
            m.poll_lost(lost.message_type(), now);
        }
        m.connection(ConnectionState::Connecting, now + Duration::from_millis(10));
    }
    answered.sort_by_key(|r| r.message_type().raw());
    assert_eq!(
        answered,
        [
            Request::Status,
            Request::MotorTemperatures,
            Request::Battery,
            Request::Perception,
        ],
        "each poll answered once in four connections"
    );
}

#[test]
fn the_status_goes_first_whenever_it_is_due() {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(0));
    assert_eq!(due(&mut m, at(0)), EVERY_POLL);
    // Only the status is taken at 5200; by 5800 perception and battery are more overdue.
    assert_eq!(m.next_poll(at(5200)), Some(Request::Status));
    assert_eq!(
        due(&mut m, at(5800)),
        [Request::Status, Request::Perception, Request::Battery]
    );
}

/// The polls asked in the first `ms`, one at a time as the application sends them, of a
/// robot that answers the status after `status_ms` and everything else at once.
fn one_at_a_time(status_ms: u64, ms: u64) -> Vec<Request> {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(0));
    let mut now = at(0);
    let mut asked = Vec::new();
    while now < at(ms) {
        let Some(request) = m.next_poll(now) else {
            now = m.next_deadline().expect("polls are scheduled");
            continue;
        };
        if request == Request::Status {
            now += Duration::from_millis(status_ms);
            m.poll_answered(&Response::Status(status()), now);
        }
        asked.push(request);
    }
    asked
}

#[test]
fn a_status_answered_slower_than_its_period_lets_the_other_polls_in_between() {
    let count =
        |asked: &[Request], request: &Request| asked.iter().filter(|r| *r == request).count();
    // Answered at once: the status every 500 ms, the others at their periods.
    let prompt = one_at_a_time(0, 30_000);
    assert_eq!(count(&prompt, &Request::Status), 60);
    assert_eq!(count(&prompt, &Request::Perception), 60);
    // 1.2 s late: the status is always due again when its answer comes, and would be asked
    // alone for good. It lets one other poll go first each time, so every poll is asked,
    // and the status still every other poll at least.
    let slow = one_at_a_time(1200, 30_000);
    for request in EVERY_POLL {
        assert!(
            count(&slow, &request) > 0,
            "{request:?} never asked: {slow:?}"
        );
    }
    assert!(
        slow.windows(2).all(|pair| pair.contains(&Request::Status)),
        "the status every other poll at least: {slow:?}"
    );
    assert!(count(&slow, &Request::Status) >= 20, "{slow:?}");
}

/// Steps the monitor from `now` to each next deadline until `request` goes out (at most
/// `limit` polls); when it went.
fn next_time_asked(
    m: &mut Monitor,
    mut now: Instant,
    request: Request,
    limit: usize,
) -> Option<u64> {
    for _ in 0..limit {
        if due(m, now).contains(&request) {
            return Some(now.as_millis());
        }
        now = m.next_deadline()?.max(now);
    }
    None
}

#[test]
fn a_poll_that_keeps_failing_is_asked_less_often_until_it_is_answered() {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(0));
    assert_eq!(due(&mut m, at(0)), EVERY_POLL);
    // The battery (every 5 s) fails each time: asked again after 10, 20, 40, then 60 s.
    let mut asked = vec![0];
    for _ in 0..5 {
        let failed = at(*asked.last().unwrap());
        m.poll_failed(MessageType::Battery, failed);
        asked.extend(next_time_asked(&mut m, failed, Request::Battery, 1000));
    }
    assert_eq!(asked, [0, 10_000, 30_000, 70_000, 130_000, 190_000]);
    // Answered: every 5 s again.
    m.poll_answered(&Response::Battery(battery()), at(190_000));
    assert_eq!(
        next_time_asked(&mut m, at(190_000), Request::Battery, 1000),
        Some(195_000)
    );
    // The status never falls back: the LEDs and the e-stop's confirmation wait on it.
    let status_due = m.next_deadline().unwrap();
    m.poll_failed(MessageType::Status, at(190_000));
    assert!(due(&mut m, status_due).contains(&Request::Status));
    // A new robot starts afresh.
    m.poll_failed(MessageType::Battery, at(195_000));
    m.connection(ConnectionState::Connecting, at(195_100));
    m.robot_moved();
    m.connection(ConnectionState::Open, at(196_000));
    assert_eq!(due(&mut m, at(196_000)), EVERY_POLL);
    assert_eq!(
        next_time_asked(&mut m, at(196_000), Request::Battery, 1000),
        Some(201_000)
    );
}

#[test]
fn a_poll_lost_again_and_again_backs_off_and_the_status_is_asked_meanwhile() {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(0));
    assert_eq!(due(&mut m, at(0)), EVERY_POLL);
    // The robot hangs up whenever it is asked 1008 (every 10 s).
    let lose = |m: &mut Monitor, now: Instant| {
        m.poll_lost(MessageType::MotorTemperatures, now);
        m.connection(ConnectionState::Connecting, now);
        m.connection(ConnectionState::Open, now + Duration::from_millis(100));
    };
    lose(&mut m, at(0));
    // Lost once: first on the next connection.
    assert_eq!(m.next_poll(at(100)), Some(Request::MotorTemperatures));
    lose(&mut m, at(100));
    // Lost again: put back 40 s (10 s doubled twice); the others go on.
    assert_eq!(due(&mut m, at(600)), [Request::Status, Request::Perception]);
    assert_eq!(
        next_time_asked(&mut m, at(600), Request::MotorTemperatures, 1000),
        Some(40_100)
    );
    // Answered: every 10 s again, and a later loss goes first once more.
    m.poll_answered(&Response::MotorTemperatures(motors_at(40.0)), at(40_100));
    lose(&mut m, at(40_100));
    assert_eq!(m.next_poll(at(40_200)), Some(Request::MotorTemperatures));
}

#[test]
fn a_late_wake_up_polls_once_and_keeps_the_period() {
    let mut m = Monitor::new(&Config::default());
    m.connection(ConnectionState::Open, at(0));
    while m.next_poll(at(0)).is_some() {}
    // Three seconds late: each poll once, not once per missed period.
    let late = due(&mut m, at(3000));
    assert_eq!(late, [Request::Status, Request::Perception]);
    assert_eq!(m.next_deadline(), Some(at(3500)));
}

#[test]
fn poll_periods_follow_the_configuration() {
    let mut config = Config::default();
    config.polls.status = Duration::from_millis(1000);
    config.polls.battery = Duration::from_millis(20_000);
    let mut m = Monitor::new(&config);
    m.connection(ConnectionState::Open, at(0));
    let p = polls(&mut m, at(0), at(60_000), |_, _| {});
    assert_eq!(counts(&p), [(1002, 60), (1008, 6), (2001, 3), (2002, 60)]);
}

#[test]
fn view_keeps_the_latest_answers() {
    let mut v = RobotView::new(&Config::default());
    assert_eq!(v.status(at(0)), None);
    v.update(&Response::Status(status()), at(100));
    let mut newer = status();
    newer.electricity = Some(79);
    v.update(&Response::Status(newer), at(600));
    assert_eq!(v.status(at(700)).and_then(|s| s.electricity), Some(79));
    v.update(&Response::Battery(battery()), at(700));
    v.update(
        &Response::Perception(Perception {
            obs_state: ObsState::ObstacleAhead,
        }),
        at(700),
    );
    let nav = NavTaskState {
        value: 1,
        status: NavTaskStatus::Running,
        error_code: NavTaskStatus::Running,
    };
    v.update(&Response::NavStatus(nav), at(700));
    let result = NavResult {
        value: 1,
        outcome: NavOutcome::Succeeded,
        status: ErrorStatus::TaskCompleted,
    };
    v.update(&Response::NavResult(result), at(800));
    // Answers to commands are not state.
    v.update(
        &Response::Light(CommandAck {
            result: CommandResult::Success,
        }),
        at(800),
    );
    assert_eq!(v.battery(at(800)), Some(&battery()));
    assert_eq!(
        v.perception(at(800)).map(|p| p.obs_state),
        Some(ObsState::ObstacleAhead)
    );
    assert_eq!(v.nav_state(at(800)), Some(&nav));
    assert_eq!(
        v.nav_result().map(|r| (r.value, r.at)),
        Some((result, at(800)))
    );
}

#[test]
fn status_older_than_2_s_is_unavailable() {
    let mut v = RobotView::new(&Config::default());
    v.update(&Response::Status(status()), at(1000));
    assert!(v.status_readable(at(2999)));
    assert_eq!(v.status_stale_at(at(2999)), Some(at(3000)));
    assert!(!v.status_readable(at(3000)));
    assert_eq!(v.status_stale_at(at(3000)), None);
    // The last answer stays available for the log, however old.
    assert_eq!(v.last_status().map(|s| s.at), Some(at(1000)));
}

#[test]
fn all_zero_status_is_unavailable_but_fresh() {
    let mut v = RobotView::new(&Config::default());
    assert!(!v.status_fresh(at(0)));
    v.update(&Response::Status(RobotStatus::UNAVAILABLE), at(0));
    assert!(!v.status_readable(at(0)));
    assert_eq!(v.status(at(0)), None);
    // The robot answered: that shows on the link LED, apart from what it said.
    assert!(v.status_fresh(at(1999)));
    assert!(!v.status_fresh(at(2000)));
}

#[test]
fn other_answers_go_stale_after_four_periods() {
    let mut v = RobotView::new(&Config::default());
    v.update(&Response::Battery(battery()), at(0));
    v.update(&Response::MotorTemperatures(motors_at(40.0)), at(0));
    assert!(v.battery(at(19_999)).is_some());
    assert!(v.battery(at(20_000)).is_none());
    assert!(v.motor_temperatures(at(39_999)).is_some());
    assert!(v.motor_temperatures(at(40_000)).is_none());
}
