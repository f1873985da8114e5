//! `route`: patrol routes, kept in files of navigation points.
//!
//! The file format is the vendor SDK's ([`file`](mod@file)); `route run` walks a route
//! point by point ([`run`](mod@run)), `route record` writes one from where the robot stands
//! ([`record`](mod@record)), and `route show` checks one and shows its points.

mod file;
mod record;
mod run;

use serde::Serialize;
use x30_panel::proto::message::NavPoint;

use crate::cli::{RouteArgs, RouteCommand};
use crate::error::Error;
use crate::render::{self, emit};
use crate::{Ctx, Interrupts};

/// Runs one `route` subcommand.
pub fn run(ctx: &Ctx, args: &RouteArgs) -> Result<(), Error> {
    match &args.command {
        RouteCommand::Run(run_args) => run::run(ctx, run_args, &Interrupts::install()?),
        RouteCommand::Record(record_args) => record::run(ctx, record_args),
        RouteCommand::Show(show_args) => {
            let points = file::load(&show_args.file)?;
            show(ctx, &points);
            Ok(())
        }
    }
}

/// One point of a route, as `route show`, `route run --dry-run` and `route record` print it
/// with `--json`.
#[derive(Debug, Serialize)]
struct PointJson<'a> {
    /// Always `route_point`.
    kind: &'static str,
    /// Position in the route, from 1.
    index: usize,
    /// The point's items, as the core serialises them.
    point: &'a NavPoint,
}

impl<'a> PointJson<'a> {
    fn new(index: usize, point: &'a NavPoint) -> Self {
        Self {
            kind: "route_point",
            index,
            point,
        }
    }
}

/// Prints the checked points: a table, or one JSON object per point.
fn show(ctx: &Ctx, points: &[NavPoint]) {
    if ctx.json {
        for (at, point) in points.iter().enumerate() {
            emit(&render::json_line(&PointJson::new(at + 1, point)));
        }
    } else {
        emit(&file::table(points));
    }
}
