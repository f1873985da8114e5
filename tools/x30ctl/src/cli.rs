//! Command-line definitions (clap derive) and their mapping onto the protocol core's types.
//!
//! Every coded value of the protocol gets a named flag value here, so users never type the
//! document's numbers (which differ between messages: the 1003 `Gait` is not the 1002
//! `GaitState`, nor the Type 2 Command 20 gait).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};
use x30_panel::proto::codes::{
    LightEffect, Manner, MotionGait, NavGait, NavMode, NavSpeed, ObsMode, PointInfo, Posture,
    Terrain,
};
use x30_panel::proto::message::{Direction, MotionCommand, NavPoint, Speed};

/// Exit statuses, shown at the end of `--help`.
const EXIT_STATUS_HELP: &str = "\
Exit status:
  0    success
  1    the robot reported a failure: a failed ErrorCode (motion, light, cancel,
       relocalize), or a navigation task that failed or was cancelled elsewhere;
       route run: a point failed, or the connection was lost while a point ran
  2    usage or validation error (bad option, value out of the document's range,
       unreadable decode input, a route file that breaks the rules or cannot be
       read or written); nothing was sent to the robot
  3    connection, timeout or protocol error: connection refused or closed, no answer
       within --timeout-ms (or --nav-timeout), a Type 0 answer (the robot could not
       read the request), or an answer that cannot be decoded
  130  interrupted by Ctrl-C (nav, route run: the task was cancelled with 1004;
       move: zero velocity was sent first)

Examples:
  x30ctl --robot 192.168.1.106:30000 status
  X30_ROBOT=10.0.0.5:30000 x30ctl battery --json
  x30ctl nav --map-id 1 --x 3.5 --y -1.2 --yaw 1.57 --point task --gait walk
  x30ctl move forward --speed 0.3 --duration 2
  x30ctl light --red 255 --effect breathing --brightness 60
  x30ctl watch --interval-ms 1000
  x30ctl decode capture.hex
  x30ctl route run patrol.json --loop 0
  x30ctl route record patrol.json --map-id 1 --point-info task";

/// Command-line client for the DEEP Robotics Jueying X30 robot_server (TCP port 30000,
/// protocol V1.0.12): every request, human-readable or JSON output.
#[derive(Debug, Parser)]
#[command(name = "x30ctl", version, after_help = EXIT_STATUS_HELP)]
pub struct Cli {
    /// Robot address, HOST:PORT (the port defaults to 30000 when left out).
    #[arg(
        long,
        global = true,
        help_heading = "Global options",
        env = "X30_ROBOT",
        default_value = "192.168.1.106:30000",
        value_name = "HOST:PORT"
    )]
    pub robot: String,

    /// Print one JSON object per answer (per event for `route`) instead of human-readable
    /// text.
    #[arg(long, global = true, help_heading = "Global options")]
    pub json: bool,

    /// How long to wait for the TCP connection to be established.
    #[arg(long, global = true, help_heading = "Global options", default_value_t = 3000, value_name = "MS",
          value_parser = clap::value_parser!(u64).range(1..=3_600_000))]
    pub connect_timeout_ms: u64,

    /// How long to wait for each answer (not the 1003 answers of `nav` and `route run`,
    /// which come when the task ends; see --nav-timeout).
    #[arg(long, global = true, help_heading = "Global options", default_value_t = 3000, value_name = "MS",
          value_parser = clap::value_parser!(u64).range(1..=3_600_000))]
    pub timeout_ms: u64,

    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands: one per request of the protocol, plus `move`, `watch`, `decode` and
/// `route`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Real-time basic status (Type 1002): motion state, pose, battery, gait, localisation.
    Status,
    /// Battery (Type 2001).
    Battery,
    /// Perception status (Type 2002): whether an obstacle is on the planned path within 2 m.
    Obstacle,
    /// Motor temperatures of the twelve joints (Type 1008).
    Motors,
    /// Navigation task status (Type 1007).
    NavStatus,
    /// Navigation task to one point (Type 1003); waits until the robot has finished it.
    ///
    /// The task is sent on its own connection, which stays open for the whole task (the
    /// robot stops a task whose client disconnects). Ctrl-C cancels the task (Type 1004,
    /// on a separate connection) and reports the cancelled answer.
    Nav(NavArgs),
    /// Cancel the running navigation task (Type 1004).
    Cancel,
    /// Zero velocity (Type 2, Command 6).
    Stop,
    /// Soft emergency stop (Type 2, Command 13), sent every 250 ms until a status confirms it.
    ///
    /// As the panel does: refusals and late answers change nothing; it ends when a status
    /// (1002) reports MotionState 6, or with exit status 3 after --timeout-ms without that.
    Estop,
    /// Stop stepping (Type 2, Command 14).
    StopStepping,
    /// Lie down (Type 2, Command 15).
    LieDown,
    /// Switch gait (Type 2, Command 20).
    Gait {
        /// The gait to switch to.
        #[arg(value_enum)]
        gait: MotionGaitArg,
    },
    /// Set the controller's indicator light (Type 1101).
    Light(LightArgs),
    /// Initialise localisation at a pose (Type 2101).
    Relocalize(RelocalizeArgs),
    /// Walk, turn or strafe for a while (Type 2 repeated at 4 Hz), then zero velocity.
    ///
    /// The command is repeated every 250 ms (the document asks for 3-5 Hz) for the
    /// duration, without waiting for answers but not while one is 500 ms overdue; then
    /// zero velocity (Command 6) is sent at once, also on Ctrl-C and on errors.
    Move(MoveArgs),
    /// Live status (1002 + 2001 + 2002), refreshed until Ctrl-C or --count refreshes.
    Watch(WatchArgs),
    /// Decode captured frames (hex text or raw bytes) from a file or standard input.
    Decode(DecodeArgs),
    /// Patrol routes: walk, record or show a file of navigation points.
    Route(RouteArgs),
}

/// Options of `nav`: every item of the 1003 request.
#[derive(Debug, Args)]
pub struct NavArgs {
    /// Target point number (echoed in the answer).
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub value: i32,
    /// Grid-map number, as in the robot's map.toml.
    #[arg(long, allow_negative_numbers = true)]
    pub map_id: i32,
    /// Target x in the map frame, m.
    #[arg(long, allow_negative_numbers = true)]
    pub x: f32,
    /// Target y in the map frame, m.
    #[arg(long, allow_negative_numbers = true)]
    pub y: f32,
    /// Target z in the map frame, m.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub z: f32,
    /// Heading at the target, rad.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub yaw: f32,
    /// What the robot does there and how it gets there.
    #[command(flatten)]
    pub style: PointStyleArgs,
    /// Give up after this many seconds: cancel the task (1004) and exit 3. Without it the
    /// answer is awaited as long as the task takes.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub nav_timeout: Option<f64>,
}

impl NavArgs {
    /// The 1003 point these options describe (not yet validated).
    pub fn point(&self) -> NavPoint {
        self.style
            .point(self.value, self.map_id, self.x, self.y, self.z, self.yaw)
    }
}

/// The 1003 items that say what a point is and how to get there: everything but its
/// number, map and pose. Shared by `nav` and `route record`.
#[derive(Debug, Args)]
pub struct PointStyleArgs {
    /// What the robot does on arrival (PointInfo).
    #[arg(long, visible_alias = "point", value_enum, default_value_t = PointArg::Task)]
    pub point_info: PointArg,
    /// Gait on the way.
    #[arg(long, value_enum, default_value_t = NavGaitArg::Walk)]
    pub gait: NavGaitArg,
    /// Speed on the way.
    #[arg(long, value_enum, default_value_t = NavSpeedArg::Normal)]
    pub speed: NavSpeedArg,
    /// Walking direction on the way.
    #[arg(long, value_enum, default_value_t = MannerArg::Forwards)]
    pub manner: MannerArg,
    /// Navigation obstacle stop/avoid, ObsMode (the robot's own terrain safety stays on
    /// either way).
    #[arg(long, visible_alias = "obstacle-avoidance", value_enum, default_value_t = ObsModeArg::On)]
    pub obs_mode: ObsModeArg,
    /// Straight line, or a planned (autonomous) path.
    #[arg(long, value_enum, default_value_t = NavModeArg::Straight)]
    pub nav_mode: NavModeArg,
    /// Terrain-map mode on the way (frame allows only the frame-stairs gaits).
    #[arg(long, value_enum, default_value_t = TerrainArg::Solid)]
    pub terrain: TerrainArg,
    /// Body height on the way (crouched allows only the walk and slope gaits).
    #[arg(long, value_enum, default_value_t = PostureArg::Normal)]
    pub posture: PostureArg,
}

impl PointStyleArgs {
    /// A 1003 point at this pose, in this style (not yet validated).
    pub fn point(&self, value: i32, map_id: i32, x: f32, y: f32, z: f32, yaw: f32) -> NavPoint {
        NavPoint {
            gait: self.gait.into(),
            speed: self.speed.into(),
            manner: self.manner.into(),
            obs_mode: self.obs_mode.into(),
            nav_mode: self.nav_mode.into(),
            terrain: self.terrain.into(),
            posture: self.posture.into(),
            ..NavPoint::new(value, map_id, x, y, z, yaw, self.point_info.into())
        }
    }
}

/// `route`'s subcommands.
#[derive(Debug, Args)]
pub struct RouteArgs {
    /// What to do with the route.
    #[command(subcommand)]
    pub command: RouteCommand,
}

/// Route files: a JSON array of points whose keys are the 1003 items (Value, MapID, PosX,
/// PosY, PosZ, AngleYaw, PointInfo, Gait, Speed, Manner, ObsMode, NavMode, Terrain,
/// Posture), the format of the vendor SDK's default_navigation_points.json.
#[derive(Debug, Subcommand)]
pub enum RouteCommand {
    /// Walk a route: one navigation task (Type 1003) per point, in order, each sent when the
    /// previous one has been reached.
    ///
    /// Every point is checked before anything is sent. Ctrl-C cancels the running point
    /// (Type 1004); a failed point or a lost connection stops the route. Each of these
    /// prints the command that resumes the route where it stopped.
    Run(RouteRunArgs),
    /// Record a route: each Enter on standard input adds the robot's pose (Type 1002) as the
    /// next point; q + Enter (or the end of the input) finishes.
    ///
    /// The file is rewritten after every point, so an interrupted recording keeps what it
    /// has.
    Record(RouteRecordArgs),
    /// Check a route file and show its points; nothing is sent.
    Show(RouteShowArgs),
}

/// Options of `route run`.
#[derive(Debug, Args)]
pub struct RouteRunArgs {
    /// The route file.
    pub file: PathBuf,
    /// Start at this point (1 = the first); later loops start at the first.
    #[arg(long, value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub from: u64,
    /// Walk the route this many times; 0 repeats it until Ctrl-C.
    #[arg(long = "loop", value_name = "K", default_value_t = 1)]
    pub loops: u64,
    /// Check the route and show what would be sent; send nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Send all points in one 1003 request (one `<Items>` block each, at most 8), as the
    /// vendor SDK does, instead of one request per point.
    #[arg(long)]
    pub single_request: bool,
}

/// Options of `route record`.
#[derive(Debug, Args)]
pub struct RouteRecordArgs {
    /// The route file to write.
    pub file: PathBuf,
    /// Grid-map number of every point, as in the robot's map.toml.
    #[arg(long, allow_negative_numbers = true)]
    pub map_id: i32,
    /// The other items of every point.
    #[command(flatten)]
    pub style: PointStyleArgs,
    /// Overwrite the file if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Options of `route show`.
#[derive(Debug, Args)]
pub struct RouteShowArgs {
    /// The route file.
    pub file: PathBuf,
}

/// Options of `light`.
#[derive(Debug, Args)]
pub struct LightArgs {
    /// Red, 0..=255.
    #[arg(long, default_value_t = 0)]
    pub red: u8,
    /// Green, 0..=255.
    #[arg(long, default_value_t = 0)]
    pub green: u8,
    /// Blue, 0..=255.
    #[arg(long, default_value_t = 0)]
    pub blue: u8,
    /// Steady or breathing.
    #[arg(long, value_enum, default_value_t = EffectArg::Steady)]
    pub effect: EffectArg,
    /// Brightness, 0..=100 %.
    #[arg(long, default_value_t = 100)]
    pub brightness: u8,
}

/// Options of `relocalize`.
#[derive(Debug, Args)]
pub struct RelocalizeArgs {
    /// x in the map frame, m.
    #[arg(long, allow_negative_numbers = true)]
    pub x: f32,
    /// y in the map frame, m.
    #[arg(long, allow_negative_numbers = true)]
    pub y: f32,
    /// z in the map frame, m.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub z: f32,
    /// Rotation about the z axis, rad.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub yaw: f32,
}

/// Options of `move`.
#[derive(Debug, Args)]
pub struct MoveArgs {
    /// Which way to move.
    #[arg(value_parser = direction_parser())]
    pub direction: Direction,
    /// Speed, m/s (rad/s for turns); the robot's default when left out. Limits: forward
    /// 1.5, backward 1.3, turns 0.45, strafes 0.15.
    #[arg(long, allow_negative_numbers = true)]
    pub speed: Option<f32>,
    /// How long to move, seconds.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub duration: f64,
}

impl MoveArgs {
    /// The Type 2 command to repeat (not yet validated). `--speed -0` is 0: the robot gets
    /// `0`, not a negative-looking `-0`.
    pub fn command(&self) -> MotionCommand {
        let speed = self
            .speed
            .map_or(Speed::Default, |speed| Speed::Value(speed + 0.0));
        MotionCommand::Move(self.direction, speed)
    }
}

/// Parses a direction by its name in the core (`forward`, `turn-left`, …), offering exactly
/// those names.
fn direction_parser() -> impl clap::builder::TypedValueParser<Value = Direction> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(Direction::ALL.map(Direction::name))
        .try_map(|name: String| Direction::from_name(&name).ok_or("not a direction"))
}

/// Options of `watch`.
#[derive(Debug, Args)]
pub struct WatchArgs {
    /// Time between refreshes.
    #[arg(long, default_value_t = 500, value_name = "MS",
          value_parser = clap::value_parser!(u64).range(1..=3_600_000))]
    pub interval_ms: u64,
    /// Stop after this many refreshes (default: until Ctrl-C).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub count: Option<u64>,
}

/// Options of `decode`.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// Capture to read; standard input when left out or `-`.
    pub file: Option<PathBuf>,
    /// How the input is written; `auto` takes it as hex when it holds only hex digits,
    /// whitespace, `0x` prefixes and `#` comment lines.
    #[arg(long, value_enum, default_value_t = InputFormat::Auto)]
    pub format: InputFormat,
    /// Also print each frame's XML body.
    #[arg(long)]
    pub xml: bool,
}

/// How `decode` reads its input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InputFormat {
    /// Hex text if it looks like hex, raw bytes otherwise.
    Auto,
    /// Hex text.
    Hex,
    /// Raw bytes as captured.
    Raw,
}

/// Generates a clap value enum and its conversion into a core code enum.
macro_rules! value_enum {
    ($(#[$meta:meta])* $name:ident => $core:ty { $($(#[$vmeta:meta])* $variant:ident => $code:ident),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
        pub enum $name {
            $($(#[$vmeta])* $variant,)+
        }

        impl From<$name> for $core {
            fn from(v: $name) -> Self {
                match v {
                    $($name::$variant => <$core>::$code,)+
                }
            }
        }
    };
}

value_enum! {
    /// `--point-info` of `nav` and `route record` (PointInfo).
    PointArg => PointInfo {
        /// Code 0: keeps stepping at the point.
        Transition => Transition,
        /// Code 1: precise arrival, then stands.
        Task => Task,
        /// Code 2: stands on arrival.
        Standing => Standing,
        /// Code 3: docks and charges.
        Charging => Charging,
    }
}

value_enum! {
    /// `--gait` of `nav` (the 1003 Gait numbering).
    NavGaitArg => NavGait {
        /// Code 0.
        Walk => Walk,
        /// Code 1: blind obstacle crossing.
        ObstacleCrossing => ObstacleCrossing,
        /// Code 2: slope/anti-slip.
        Slope => Slope,
        /// Code 4.
        PerceptionStairs => PerceptionStairs,
        /// Code 6: accumulated-frame stairs.
        FrameStairs => AccumulatedFrameStairs,
        /// Code 7: accumulated-frame 45-degree stairs.
        #[value(name = "frame-stairs-45")]
        FrameStairs45 => AccumulatedFrameStairs45,
    }
}

value_enum! {
    /// `--speed` of `nav`.
    NavSpeedArg => NavSpeed {
        /// Code 0.
        Normal => Normal,
        /// Code 1.
        Low => Low,
        /// Code 2.
        High => High,
    }
}

value_enum! {
    /// `--manner` of `nav`.
    MannerArg => Manner {
        /// Code 0.
        Forwards => Forwards,
        /// Code 1.
        Backwards => Backwards,
    }
}

value_enum! {
    /// `--obs-mode` of `nav` and `route record` (note the protocol's inverted codes).
    ObsModeArg => ObsMode {
        /// Code 0: navigation obstacle stop/avoid on.
        On => Enabled,
        /// Code 1: off.
        Off => Disabled,
    }
}

value_enum! {
    /// `--nav-mode` of `nav`.
    NavModeArg => NavMode {
        /// Code 0: straight line (fails if no straight path can be planned).
        Straight => StraightLine,
        /// Code 1: planned path.
        Autonomous => Autonomous,
    }
}

value_enum! {
    /// `--terrain` of `nav`.
    TerrainArg => Terrain {
        /// Code 0: solid ground.
        Solid => Solid,
        /// Code 1: hollow grating.
        Grating => HollowGrating,
        /// Code 2: open-riser stairs.
        OpenRiser => OpenRiserStairs,
        /// Code 3: accumulated frame.
        Frame => AccumulatedFrame,
    }
}

value_enum! {
    /// `--posture` of `nav`.
    PostureArg => Posture {
        /// Code 0.
        Normal => Normal,
        /// Code 1.
        Crouched => Crouched,
    }
}

value_enum! {
    /// The gait of `gait` (Type 2 Command 20 numbering).
    MotionGaitArg => MotionGait {
        /// Code 0.
        Walk => Walk,
        /// Code 1: normal stairs.
        Stairs => NormalStairs,
        /// Code 2: slope/anti-slip.
        Slope => Slope,
        /// Code 4.
        PerceptionStairs => PerceptionStairs,
    }
}

value_enum! {
    /// `--effect` of `light`.
    EffectArg => LightEffect {
        /// Code 0.
        Steady => Steady,
        /// Code 1.
        Breathing => Breathing,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        Cli::command().debug_assert();
    }
}
