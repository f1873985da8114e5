//! A logger that records every line logged at warning level or above, for the tests that
//! check what is logged. The logger is process-wide: each such test file is a test binary
//! of its own, and its tests look only for lines of their own.

use std::sync::{Mutex, Once};

/// Every line logged at warning level or above.
static WARNINGS: Mutex<Vec<String>> = Mutex::new(Vec::new());

struct Recorder;

impl log::Log for Recorder {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::Level::Warn
    }

    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            WARNINGS.lock().unwrap().push(record.args().to_string());
        }
    }

    fn flush(&self) {}
}

static RECORDER: Recorder = Recorder;

/// Starts recording warnings; the tests run side by side, and the logger can be set once.
pub fn record_warnings() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        log::set_logger(&RECORDER).unwrap();
        log::set_max_level(log::LevelFilter::Warn);
    });
}

/// The recorded warnings, in the order they were logged, that contain `what`.
pub fn warnings_with(what: &str) -> Vec<String> {
    let warnings = WARNINGS.lock().unwrap();
    warnings
        .iter()
        .filter(|w| w.contains(what))
        .cloned()
        .collect()
}
