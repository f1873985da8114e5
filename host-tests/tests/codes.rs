//! Tests of `x30_panel::proto::codes`: every coded enum against a table of the protocol's
//! (raw, variant) pairs written out here, independently of the macro invocation in the crate.

use std::collections::HashSet;
use std::fmt::{Debug, Display};
use std::hash::Hash;

use x30_panel::proto::codes::*;

/// The generated API, behind one trait so each check is written once for every enum.
trait Code: Copy + Eq + Hash + Debug + Display + From<i32> + Into<i32> {
    const NAME: &'static str;
    fn from_raw(raw: i32) -> Self;
    fn raw(self) -> i32;
    fn is_known(self) -> bool;
    fn description(self) -> &'static str;
    fn unknown(raw: i32) -> Self;
}

/// Implements [`Code`] for each enum and defines its table, `[(raw, variant)]`.
macro_rules! tables {
    ($( $table:ident: $t:ident { $($raw:literal => $v:ident),+ $(,)? } )+) => {
        $(
            impl Code for $t {
                const NAME: &'static str = stringify!($t);
                fn from_raw(raw: i32) -> Self { $t::from_raw(raw) }
                fn raw(self) -> i32 { $t::raw(self) }
                fn is_known(self) -> bool { $t::is_known(self) }
                fn description(self) -> &'static str { $t::description(self) }
                fn unknown(raw: i32) -> Self { $t::Unknown(raw) }
            }
            const $table: &[(i32, $t)] = &[$(($raw, $t::$v)),+];
        )+

        /// Runs a generic check on every table.
        macro_rules! for_each_table {
            ($check:ident) => { $( $check($table); )+ };
        }
    };
}

tables! {
    MESSAGE_TYPE: MessageType {
        0 => RequestError, 2 => Motion, 1002 => Status, 1003 => NavTask, 1004 => CancelNav,
        1007 => NavStatus, 1008 => MotorTemperatures, 1101 => Light, 2001 => Battery,
        2002 => Perception, 2101 => Relocalize,
    }
    MOTION_COMMAND_CODE: MotionCommandCode {
        1 => Forward, 2 => Backward, 3 => TurnLeft, 4 => TurnRight, 6 => ZeroVelocity,
        11 => StrafeLeft, 12 => StrafeRight, 13 => SoftEmergencyStop, 14 => StopStepping,
        15 => LieDown, 20 => SwitchGait,
        // vendor-extensions (enabled by this crate's dependency on x30-panel)
        16 => StandUp, 17 => ForceControl, 18 => StartStepping, 19 => BodyHeight,
        21 => GoCharging, 22 => LeaveCharger,
    }
    MOTION_STATE: MotionState {
        0 => LyingDown, 1 => StandingUp, 2 => InitialStand, 3 => ForceControlStand,
        4 => Stepping, 5 => LyingDownInProgress, 6 => SoftEmergencyStop, 7 => Fallen,
    }
    GAIT_STATE: GaitState {
        0 => Walk, 1 => ObstacleCrossing, 2 => Slope, 6 => PerceptionStairs,
        7 => AccumulatedFrameStairs, 8 => AccumulatedFrameStairs45,
    }
    NAV_GAIT: NavGait {
        0 => Walk, 1 => ObstacleCrossing, 2 => Slope, 4 => PerceptionStairs,
        6 => AccumulatedFrameStairs, 7 => AccumulatedFrameStairs45,
    }
    MOTION_GAIT: MotionGait { 0 => Walk, 1 => NormalStairs, 2 => Slope, 4 => PerceptionStairs }
    POINT_INFO: PointInfo { 0 => Transition, 1 => Task, 2 => Standing, 3 => Charging }
    NAV_SPEED: NavSpeed { 0 => Normal, 1 => Low, 2 => High }
    MANNER: Manner { 0 => Forwards, 1 => Backwards }
    OBS_MODE: ObsMode { 0 => Enabled, 1 => Disabled }
    NAV_MODE: NavMode { 0 => StraightLine, 1 => Autonomous }
    TERRAIN: Terrain { 0 => Solid, 1 => HollowGrating, 2 => OpenRiserStairs, 3 => AccumulatedFrame }
    POSTURE: Posture { 0 => Normal, 1 => Crouched }
    LOCATION: Location { 0 => Localized, 1 => Lost }
    MOTOR_STATE: MotorState { 0 => Normal, 1 => OverTemperature }
    CHARGE_STATE: ChargeState { 0 => NotCharging, 1 => Charging }
    CONTROL_MODE: ControlMode { 0 => Manual, 1 => Automatic }
    ON_DOCK_STATE: OnDockState { 0 => OffDock, 1 => OnDock }
    NAV_OUTCOME: NavOutcome { 0 => Succeeded, 1 => Failed, 2 => Cancelled }
    ERROR_STATUS: ErrorStatus {
        0 => Default, 8960 => TaskCompleted, 8962 => TaskCancelled,
        41729 => MotionStateAbnormal, 41730 => BatteryTooLow, 41731 => MotorOverTemperature,
        41732 => ChargingOnCharger, 41745 => NavigationNotRunning,
        41746 => NavigationCommError, 41747 => LocalizationAbnormal,
        41748 => TerrainModuleAbnormal, 41761 => SendStandUpFailed, 41762 => StandUpFailed,
        41763 => ForceControlFailed, 41764 => WalkingModeFailed, 41765 => LieDownFailed,
        41766 => SoftEmergencyStopped, 41767 => GaitSwitchFailed, 41768 => NavModeSwitchFailed,
        41769 => ManualModeSwitchFailed, 41770 => PostureSwitchFailed,
        41777 => ObstacleSpeedSourceFailed, 41778 => TerrainMapParamsFailed,
        41793 => TaskAlreadyRunning, 41794 => ScheduleLeaveChargingFailed,
        41795 => LeaveChargingFailed, 41796 => ScheduleEnterChargingFailed,
        41797 => EnterChargingFailed, 41798 => RelocalizeAfterUndockFailed,
        41799 => EnableAccumulatedFrameFailed, 41800 => DisableAccumulatedFrameFailed,
        41801 => MapSwitchFailed, 41802 => ClientDisconnected, 41803 => ObstacleStopTooLong,
        41804 => GlobalPlanningFailed, 41805 => NavSpeedNotRefreshed,
        41806 => AutoChargingInProgress, 41881 => RelocalizationFailed,
        41983 => ProcessRestarting,
    }
    NAV_TASK_STATUS: NavTaskStatus { -1 => CannotRun, 0 => Finished, 1 => Running }
    LIGHT_EFFECT: LightEffect { 0 => Steady, 1 => Breathing }
    REQUEST_ERROR_CODE: RequestErrorCode {
        1 => HeaderMissing, 2 => HeaderWrong, 3 => LengthAbnormal, 4 => ParseFailed,
    }
    COMMAND_RESULT: CommandResult { 0 => Success, 1 => Failure }
    LOCALIZATION_RESULT: LocalizationResult { 0 => Localized, 1 => Abnormal }
    OBS_STATE: ObsState { 0 => Clear, 1 => ObstacleAhead }
    PROTECTED_STATE: ProtectedState { 0 => Normal, 1 => Triggered }
}

/// Raw values no enum defines.
const UNKNOWN_RAWS: [i32; 7] = [99, -5, 41999, 5, -2, i32::MIN, i32::MAX];

fn known_round_trip<T: Code>(table: &[(i32, T)]) {
    for &(raw, code) in table {
        assert_eq!(T::from_raw(raw), code, "{}::from_raw({raw})", T::NAME);
        assert_eq!(T::from(raw), code, "{}::from({raw})", T::NAME);
        assert_eq!(code.raw(), raw, "{code:?}.raw()");
        assert_eq!(code.into(), raw, "i32::from({code:?})");
        assert!(code.is_known(), "{code:?}.is_known()");
    }
}

fn unknown_round_trip<T: Code>(table: &[(i32, T)]) {
    for raw in UNKNOWN_RAWS {
        if table.iter().any(|&(r, _)| r == raw) {
            continue; // e.g. 5 is a MotionState
        }
        let code = T::from_raw(raw);
        assert_eq!(code, T::unknown(raw), "{}::from_raw({raw})", T::NAME);
        assert_eq!(code.raw(), raw, "{code:?}.raw()");
        assert_eq!(code.into(), raw, "i32::from({code:?})");
        assert!(!code.is_known(), "{code:?}.is_known()");
        assert_eq!(code.description(), "unknown code", "{code:?}.description()");
    }
}

fn only_table_codes_known<T: Code>(table: &[(i32, T)]) {
    let known: HashSet<i32> = table.iter().map(|&(raw, _)| raw).collect();
    assert_eq!(
        known.len(),
        table.len(),
        "{}: duplicate raw in the test table",
        T::NAME
    );
    for raw in -1000..=43000 {
        assert_eq!(
            T::from_raw(raw).is_known(),
            known.contains(&raw),
            "{}::from_raw({raw})",
            T::NAME
        );
    }
}

fn descriptions_distinct<T: Code>(table: &[(i32, T)]) {
    let mut seen = HashSet::new();
    let variants: HashSet<T> = table.iter().map(|&(_, code)| code).collect();
    assert_eq!(
        variants.len(),
        table.len(),
        "{}: duplicate variant in the test table",
        T::NAME
    );
    for &(_, code) in table {
        let text = code.description();
        assert!(!text.trim().is_empty(), "{code:?} has an empty description");
        assert_ne!(text, "unknown code", "{code:?} is described as unknown");
        assert!(
            seen.insert(text),
            "{}: description {text:?} used twice",
            T::NAME
        );
    }
}

fn display_is_description<T: Code>(table: &[(i32, T)]) {
    for &(_, code) in table.iter().chain(&[(0, T::unknown(41999))]) {
        assert_eq!(code.to_string(), code.description(), "{code:?}");
    }
}

#[test]
fn every_known_code_round_trips_and_is_known() {
    for_each_table!(known_round_trip);
}

#[test]
fn unknown_codes_are_kept_as_received() {
    for_each_table!(unknown_round_trip);
}

#[test]
fn only_the_tabled_codes_are_known() {
    for_each_table!(only_table_codes_known);
}

#[test]
fn descriptions_are_non_empty_and_distinct_within_each_enum() {
    for_each_table!(descriptions_distinct);
}

#[test]
fn display_writes_the_description() {
    for_each_table!(display_is_description);
    let status = ErrorStatus::from_raw(41730);
    assert_eq!(
        format!("ErrorStatus {}, \"{status}\"", status.raw()),
        "ErrorStatus 41730, \"battery too low\""
    );
}

#[test]
fn error_status_battery_too_low() {
    let status = ErrorStatus::from_raw(41730);
    assert_eq!(status, ErrorStatus::BatteryTooLow);
    assert_eq!(status.description(), "battery too low");
}

#[test]
fn nav_task_status_minus_one_is_cannot_run() {
    assert_eq!(NavTaskStatus::from_raw(-1), NavTaskStatus::CannotRun);
    assert_eq!(NavTaskStatus::CannotRun.raw(), -1);
}

#[test]
fn vendor_extension_motion_commands_are_known() {
    use MotionCommandCode::*;
    for (raw, code) in [
        (16, StandUp),
        (17, ForceControl),
        (18, StartStepping),
        (19, BodyHeight),
        (21, GoCharging),
        (22, LeaveCharger),
    ] {
        assert_eq!(MotionCommandCode::from_raw(raw), code);
        assert!(code.is_known(), "{code:?}");
    }
    assert_eq!(MotionCommandCode::from_raw(23), Unknown(23));
}

#[test]
fn gait_numberings_differ_between_status_and_navigation() {
    assert_eq!(GaitState::PerceptionStairs.raw(), 6);
    assert_eq!(NavGait::PerceptionStairs.raw(), 4);
    assert_eq!(MotionGait::PerceptionStairs.raw(), 4);
    assert_eq!(NavGait::from_raw(8), NavGait::Unknown(8));
}

#[test]
fn motion_state_soft_emergency_stop_helper() {
    for &(_, state) in MOTION_STATE {
        assert_eq!(
            state.is_soft_emergency_stop(),
            state == MotionState::SoftEmergencyStop
        );
    }
    assert!(!MotionState::Unknown(6_000).is_soft_emergency_stop());
}

#[test]
fn error_status_failure_is_anything_but_default_completed_cancelled() {
    for &(_, status) in ERROR_STATUS {
        let benign = matches!(
            status,
            ErrorStatus::Default | ErrorStatus::TaskCompleted | ErrorStatus::TaskCancelled
        );
        assert_eq!(status.is_failure(), !benign, "{status:?}");
    }
    assert!(ErrorStatus::from_raw(41999).is_failure());
}

#[test]
fn success_helpers() {
    assert!(NavOutcome::Succeeded.is_success());
    assert!(!NavOutcome::Failed.is_success());
    assert!(!NavOutcome::Cancelled.is_success());
    assert!(!NavOutcome::Unknown(3).is_success());
    assert!(CommandResult::Success.is_success());
    assert!(!CommandResult::Failure.is_success());
    assert!(!CommandResult::Unknown(2).is_success());
}

#[test]
fn conversions_are_usable_in_const_context() {
    const STATE: MotionState = MotionState::from_raw(7);
    const RAW: i32 = ErrorStatus::ProcessRestarting.raw();
    const KNOWN: [bool; 2] = [
        MessageType::from_raw(1002).is_known(),
        MessageType::from_raw(99).is_known(),
    ];
    const TEXT: &str = ObsMode::Enabled.description();
    assert_eq!(STATE, MotionState::Fallen);
    assert_eq!(RAW, 41983);
    assert_eq!(KNOWN, [true, false]);
    assert_eq!(TEXT, "obstacle stop/avoid on");
}
