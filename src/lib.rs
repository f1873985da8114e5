//! x30-panel: a button panel for the DEEP Robotics Jueying X30 inspection robot.
//!
//! This crate is the portable core of the panel firmware. [`proto`] is the pure codec of the
//! robot's `robot_server` protocol (V1.0.12): frames, XML, and typed messages for every Type,
//! with no I/O, no allocation and no panics. [`client`] talks to the robot over any async byte
//! stream (message IDs, timeouts, reconnection). [`panel`] is the panel's logic (buttons,
//! control, monitor, indicators) as state machines fed with events and time, and [`config`]
//! holds the build-time settings.
#![no_std]
#![deny(unsafe_code)]
// The library never panics: a panel must keep running, so failures are values, not aborts.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::unreachable,
    clippy::todo,
    clippy::unimplemented
)]
#![warn(missing_docs)]

// Otherwise the mistake shows only at link time, as undefined `_defmt_*` symbols.
#[cfg(all(feature = "defmt", not(target_os = "none")))]
compile_error!(
    "the `defmt` feature links only on bare-metal targets, and the Nucleo board feature turns \
     it on: on the host, depend on x30-panel without a board feature or `defmt`"
);

// First, so that every module below can use the logging macros.
#[macro_use]
mod fmt;

pub mod app;
pub mod client;
pub mod config;
pub mod console;
pub mod panel;
pub mod proto;
pub mod settings;
pub mod web;
