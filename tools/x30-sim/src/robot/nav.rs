//! A navigation task (Type 1003) under way: its waypoints walked in order, in straight lines.

use std::time::Duration;

use serde::Serialize;
use x30_panel::proto::codes::{Manner, NavSpeed};
use x30_panel::proto::message::{NavPoint, NavResult};

use super::motion::wrap_angle;
use super::{Pose, Requester};

/// Walking speed for a 1003 `Speed` code, m/s: normal 0.5, low 0.25, high 1.0.
pub fn nav_speed(speed: NavSpeed) -> f64 {
    match speed {
        NavSpeed::Low => 0.25,
        NavSpeed::High => 1.0,
        // Validation refuses unknown codes before a task starts.
        NavSpeed::Normal | NavSpeed::Unknown(_) => 0.5,
    }
}

/// What a navigation task did, as the request log records it (`"event"` names the kind).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum TaskEvent {
    /// The robot set out for a waypoint: number `index` (from 1) of the task's `of`,
    /// whose `Value` is `value`.
    Waypoint {
        /// Position in the task, from 1.
        index: usize,
        /// Waypoints in the task.
        of: usize,
        /// The waypoint's `Value`.
        value: i32,
    },
    /// The task ended with an answer carrying `value`, `error_code` and `error_status`,
    /// after reaching `reached` of its `of` waypoints.
    Ended {
        /// Waypoints reached.
        reached: usize,
        /// Waypoints in the task.
        of: usize,
        /// The answer's `Value`.
        value: i32,
        /// The answer's `ErrorCode`.
        error_code: i32,
        /// The answer's `ErrorStatus`.
        error_status: i32,
    },
}

impl TaskEvent {
    /// The event for a task that ended with `result`.
    pub fn ended(task: &Task, result: &NavResult) -> Self {
        Self::Ended {
            reached: task.reached(),
            of: task.len(),
            value: result.value,
            error_code: result.outcome.raw(),
            error_status: result.status.raw(),
        }
    }
}

/// A [`TaskEvent`] with the task it belongs to and when it happened.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskProgress {
    /// The 1003 request's connection and message ID.
    pub owner: Requester,
    /// Real time since the simulator started.
    pub at: Duration,
    /// What happened.
    pub event: TaskEvent,
}

/// A running navigation task.
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    /// Who asked for it: its answer goes back there.
    pub owner: Requester,
    points: Vec<NavPoint>,
    /// Index of the waypoint being walked to; `points.len()` once all are reached.
    next: usize,
    /// Simulated time since which an obstacle has held the robot up, s.
    pub obstacle_since: Option<f64>,
}

impl Task {
    /// A task through `points`, in order, none reached yet.
    pub fn new(owner: Requester, points: &[NavPoint]) -> Self {
        Self {
            owner,
            points: points.to_vec(),
            next: 0,
            obstacle_since: None,
        }
    }

    /// The last waypoint's number, which the 1003 answer carries.
    pub fn value(&self) -> i32 {
        self.points.last().map_or(0, |p| p.value)
    }

    /// The waypoint being walked to; `None` once all are reached.
    pub fn current(&self) -> Option<&NavPoint> {
        self.points.get(self.next)
    }

    /// The last waypoint.
    pub fn final_point(&self) -> Option<&NavPoint> {
        self.points.last()
    }

    /// Number of waypoints.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Number of waypoints reached so far.
    pub fn reached(&self) -> usize {
        self.next
    }

    /// The number the answer carries when the task ends now: the last waypoint's once all
    /// are reached, otherwise the one being walked to, so that a client learns where the
    /// task stopped.
    pub fn ended_value(&self) -> i32 {
        self.current().map_or(self.value(), |p| p.value)
    }

    /// Whether every waypoint has been reached.
    pub fn is_done(&self) -> bool {
        self.next >= self.points.len()
    }

    /// The event for setting out for the waypoint at `index` (from 0), if there is one.
    pub fn set_out(&self, index: usize) -> Option<TaskEvent> {
        self.points.get(index).map(|p| TaskEvent::Waypoint {
            index: index + 1,
            of: self.points.len(),
            value: p.value,
        })
    }

    /// The forward speed the robot reports while walking to the current waypoint, m/s:
    /// negative when it walks backwards.
    pub fn reported_speed(&self) -> f64 {
        self.current().map_or(0.0, |p| {
            let speed = nav_speed(p.speed);
            if p.manner == Manner::Backwards {
                -speed
            } else {
                speed
            }
        })
    }

    /// Walks towards the waypoints for `dt` simulated seconds, moving `pose`; returns the
    /// distance covered, m.
    ///
    /// A waypoint is reached exactly when distance / speed has elapsed, so the task never
    /// ends before its walking time. On reaching one the robot takes its `AngleYaw`; on the
    /// way it faces along the path (away from it when walking backwards). The walk stops
    /// short of any waypoint `unreachable` accepts: the robot cannot set out for it.
    pub fn walk(
        &mut self,
        pose: &mut Pose,
        dt: f64,
        unreachable: impl Fn(&NavPoint) -> bool,
    ) -> f64 {
        let mut left = dt.max(0.0);
        let mut covered = 0.0;
        while let Some(point) = self.points.get(self.next).filter(|p| !unreachable(p)) {
            let speed = nav_speed(point.speed);
            let (dx, dy, dz) = (
                f64::from(point.pos_x) - pose.x,
                f64::from(point.pos_y) - pose.y,
                f64::from(point.pos_z) - pose.z,
            );
            let distance = (dx * dx + dy * dy + dz * dz).sqrt();
            let reach = speed * left;
            if distance <= reach {
                *pose = Pose {
                    x: f64::from(point.pos_x),
                    y: f64::from(point.pos_y),
                    z: f64::from(point.pos_z),
                    yaw: wrap_angle(f64::from(point.angle_yaw)),
                };
                covered += distance;
                left = (left - distance / speed).max(0.0);
                self.next += 1;
                continue;
            }
            if left > 0.0 {
                let fraction = reach / distance;
                pose.x += dx * fraction;
                pose.y += dy * fraction;
                pose.z += dz * fraction;
                if dx.hypot(dy) > 1e-9 {
                    let heading = dy.atan2(dx);
                    let backwards = point.manner == Manner::Backwards;
                    pose.yaw = wrap_angle(if backwards {
                        heading + std::f64::consts::PI
                    } else {
                        heading
                    });
                }
                covered += reach;
            }
            break;
        }
        covered
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use x30_panel::proto::codes::PointInfo;

    fn point(value: i32, x: f32, y: f32, speed: NavSpeed) -> NavPoint {
        NavPoint {
            speed,
            ..NavPoint::new(value, 1, x, y, 0.0, 1.0, PointInfo::Standing)
        }
    }

    /// Every waypoint is reachable.
    fn never(_: &NavPoint) -> bool {
        false
    }

    const OWNER: Requester = Requester {
        conn: 1,
        message_id: 7,
    };

    #[test]
    fn walks_waypoints_in_order_at_their_speed() {
        let points = [
            point(1, 3.0, 0.0, NavSpeed::Normal),
            point(2, 3.0, 4.0, NavSpeed::High),
        ];
        let mut task = Task::new(OWNER, &points);
        let mut pose = Pose::default();
        // 3 m at 0.5 m/s takes 6 s.
        assert!((task.walk(&mut pose, 5.0, never) - 2.5).abs() < 1e-9);
        assert!((pose.x - 2.5).abs() < 1e-9 && pose.yaw.abs() < 1e-9);
        assert_eq!(task.reached(), 0);
        // One more second reaches the first point exactly; the second is 4 m at 1 m/s.
        task.walk(&mut pose, 1.0, never);
        assert_eq!(task.reached(), 1);
        assert_eq!(pose.yaw, 1.0);
        task.walk(&mut pose, 3.999, never);
        assert!(!task.is_done());
        task.walk(&mut pose, 0.001, never);
        assert!(task.is_done());
        assert_eq!((pose.x, pose.y), (3.0, 4.0));
        assert_eq!(task.value(), 2);
    }

    #[test]
    fn leftover_time_carries_into_the_next_leg() {
        let points = [
            point(1, 1.0, 0.0, NavSpeed::High),
            point(2, 2.0, 0.0, NavSpeed::Low),
        ];
        let mut task = Task::new(OWNER, &points);
        let mut pose = Pose::default();
        // 1 s for the first metre, then 1 s at 0.25 m/s.
        let covered = task.walk(&mut pose, 2.0, never);
        assert!((covered - 1.25).abs() < 1e-9, "{covered}");
        assert!((pose.x - 1.25).abs() < 1e-9);
    }

    #[test]
    fn the_walk_stops_short_of_an_unreachable_waypoint() {
        let points = [
            point(1, 1.0, 0.0, NavSpeed::High),
            point(2, 2.0, 0.0, NavSpeed::High),
        ];
        let mut task = Task::new(OWNER, &points);
        let mut pose = Pose::default();
        assert_eq!(task.ended_value(), 1);
        let covered = task.walk(&mut pose, 5.0, |p| p.value == 2);
        assert!((covered - 1.0).abs() < 1e-9, "{covered}");
        assert_eq!((task.reached(), pose.x), (1, 1.0));
        // Stopped now, the task names the waypoint it did not reach; done, the last one.
        assert_eq!(task.ended_value(), 2);
        task.walk(&mut pose, 1.0, never);
        assert!(task.is_done());
        assert_eq!(task.ended_value(), 2);
    }

    #[test]
    fn a_point_where_the_robot_stands_is_reached_at_once() {
        let mut task = Task::new(OWNER, &[point(9, 0.0, 0.0, NavSpeed::Normal)]);
        let mut pose = Pose::default();
        assert_eq!(task.walk(&mut pose, 0.0, never), 0.0);
        assert!(task.is_done());
    }
}
