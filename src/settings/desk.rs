//! Saving settings, and the desk where the console and the web page meet to do it.
//!
//! One task owns the settings and their store: the console's ([`crate::console::run`]). It
//! saves what is typed on the serial port, and it also takes the web page's changes from the
//! [`Desk`]: the web task applies a form to a copy of the settings the owner published there
//! and leaves the copy on the desk ([`Desk::save_with`]); the owner saves it as it would a
//! `save` typed on the console, with the same checks, and answers. So there is one store,
//! one set of edits and one rule for when saving is allowed, whoever asks.

use core::cell::RefCell;
use core::fmt;

use embassy_sync::blocking_mutex::Mutex as BlockingMutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant};
use embedded_storage_async::nor_flash::NorFlash;

use super::store::{BLOB_MAX, BUF_LEN, Store, StoreError};
use super::{Conflict, Keys, Settings, Unsaved};
use crate::app::Shared;
use crate::panel::Busy;

/// A save that happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Saved {
    /// The keys whose values changed.
    pub keys: Keys,
    /// How long the store took.
    pub took: Duration,
    /// Flash pages the store erased (each one stalls some chips).
    pub erases: u32,
    /// Whether the robot's address changed: the panel reconnects.
    pub moved: bool,
    /// Whether the route changed.
    pub route: bool,
}

/// Why a save did not happen; the settings in effect are unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Refused {
    /// Nothing differs from what is saved.
    NothingChanged,
    /// The edits contradict each other.
    Conflict(Conflict),
    /// The panel is doing something a flash erase must not delay.
    Busy(Busy),
    /// The settings do not fit the store.
    TooLarge,
    /// The flash failed; saving again may work.
    Flash(StoreError),
    /// Nobody owns the settings (the console task is not running).
    NoOwner,
    /// The edits were made on settings that have been saved over since (a page loaded
    /// before a save on the console): saved, they would undo that save.
    Stale,
}

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NothingChanged => f.write_str("nothing changed; nothing to save"),
            Self::Conflict(conflict) => write!(f, "not saved: {conflict}"),
            Self::Busy(busy) => write!(
                f,
                "not saved: {}; save when the panel is idle",
                busy.description()
            ),
            Self::TooLarge => f.write_str("not saved: the settings do not fit the store"),
            Self::Flash(e) => write!(
                f,
                "not saved: the flash failed ({e}); the settings in effect are unchanged"
            ),
            Self::NoOwner => f.write_str("not saved: the settings are not available yet"),
            Self::Stale => f.write_str(
                "not saved: the settings were saved elsewhere since they were shown here; \
                 these are the settings now, make the change again",
            ),
        }
    }
}

/// Why the panel must not save now: what the application reports, or a button event it has
/// not taken in yet.
pub fn busy(shared: &Shared) -> Option<Busy> {
    let panel = shared.snapshot().and_then(|s| s.busy);
    if panel.is_none() && !shared.buttons.is_empty() {
        // The event may be a motion press or a stop: let the panel see it first.
        return Some(Busy::StopPending);
    }
    panel
}

/// Whether `settings`' edits may be saved while the panel is `busy` (or not).
pub fn check(settings: &Settings, busy: Option<Busy>) -> Result<(), Refused> {
    if settings.unsaved_changes().is_empty() {
        return Err(Refused::NothingChanged);
    }
    settings.check().map_err(Refused::Conflict)?;
    match busy {
        Some(busy) => Err(Refused::Busy(busy)),
        None => Ok(()),
    }
}

/// Saves the edited settings through `store` and puts them in effect, unless [`check`]
/// refuses, asked right before the flash work.
pub async fn save<F: NorFlash>(
    store: &mut Store<F>,
    settings: &mut Settings,
    shared: &Shared,
) -> Result<Saved, Refused> {
    check(settings, busy(shared))?;
    let mut blob = [0u8; BLOB_MAX];
    let len = settings.emit(&mut blob).ok_or(Refused::TooLarge)?;
    let mut scratch = [0u8; BUF_LEN];
    let Unsaved { keys, route } = settings.unsaved_changes();
    let moved = settings.edited().robot != settings.config().robot;
    let started = Instant::now();
    let result = store
        .save(blob.get(..len).unwrap_or_default(), &mut scratch)
        .await;
    let took = Instant::now().saturating_duration_since(started);
    match result {
        Ok(()) => {}
        // A stop or a press came while the pages were read: the erase it needed waits.
        Err(StoreError::Held) => {
            info!("settings: save held back before a page erase");
            return Err(Refused::Busy(busy(shared).unwrap_or(Busy::StopPending)));
        }
        Err(e) => {
            warn!("settings: save failed: {:?}", e);
            return Err(Refused::Flash(e));
        }
    }
    settings.commit();
    shared.set_settings_lost(false);
    shared.apply_settings(settings.config().clone());
    info!("settings: saved in {} ms", took.as_millis());
    Ok(Saved {
        keys,
        took,
        erases: store.last_save_erases(),
        moved,
        route,
    })
}

/// Where the settings' owner publishes them and takes other tasks' edits to save.
///
/// Settings are 4 KiB, and every copy held across an `await` takes that much of a task's
/// future, which the board keeps in static RAM. So edits stay on the desk: the owner swaps
/// them with its own settings in place ([`Desk::take_edits`]), and its own settings wait
/// on the desk until it answers ([`Desk::answer`]).
pub struct Desk {
    /// The owner's settings, as of its last change.
    published: BlockingMutex<CriticalSectionRawMutex, RefCell<Option<Settings>>>,
    /// One request at a time.
    turn: Mutex<CriticalSectionRawMutex, ()>,
    /// Edited settings to save, then the owner's while it saves them.
    pending: BlockingMutex<CriticalSectionRawMutex, RefCell<Slot>>,
    /// Rings when edits are pending.
    requests: Signal<CriticalSectionRawMutex, ()>,
    /// The owner's answer.
    replies: Signal<CriticalSectionRawMutex, Result<Saved, Refused>>,
}

/// What waits on the desk besides the published settings.
enum Slot {
    /// Nothing.
    Empty,
    /// Edits for the owner to save.
    Edits(Settings),
    /// The owner's own settings, set aside while it saves edits in their place.
    SetAside(Settings),
}

impl Default for Desk {
    fn default() -> Self {
        Self::new()
    }
}

impl Desk {
    /// An empty desk, for a `static`.
    pub const fn new() -> Self {
        Self {
            published: BlockingMutex::new(RefCell::new(None)),
            turn: Mutex::new(()),
            pending: BlockingMutex::new(RefCell::new(Slot::Empty)),
            requests: Signal::new(),
            replies: Signal::new(),
        }
    }

    /// The owner's settings (a copy); `None` before the owner runs.
    pub fn settings(&self) -> Option<Settings> {
        self.published.lock(|cell| cell.borrow().clone())
    }

    /// Has the owner save its settings as `edit` changes them, and waits for the answer.
    /// `edit` works on a copy of the published settings, before anything is sent; its error
    /// is returned as it is, and then nothing is saved.
    pub async fn save_with<E: From<Refused>>(
        &self,
        edit: impl FnOnce(&mut Settings) -> Result<(), E>,
    ) -> Result<Saved, E> {
        if self.published.lock(|cell| cell.borrow().is_none()) {
            return Err(Refused::NoOwner.into());
        }
        let _turn = self.turn.lock().await;
        // A caller that gave up its wait leaves its save running: its answer comes first,
        // and the owner's settings set aside for it stay where they are.
        while self
            .pending
            .lock(|cell| matches!(*cell.borrow(), Slot::SetAside(_)))
        {
            let _theirs = self.replies.wait().await;
        }
        // The copy lives in this block only: held across the wait below, it would take
        // 4 KiB of the caller's future.
        {
            let mut edited = self.settings().ok_or(Refused::NoOwner)?;
            edit(&mut edited)?;
            self.replies.reset();
            self.pending
                .lock(|cell| *cell.borrow_mut() = Slot::Edits(edited));
        }
        self.requests.signal(());
        Ok(self.replies.wait().await?)
    }

    /// The owner: publishes its settings.
    pub fn publish(&self, settings: &Settings) {
        self.published
            .lock(|cell| *cell.borrow_mut() = Some(settings.clone()));
    }

    /// The owner: waits until edits are pending.
    pub async fn request(&self) {
        self.requests.wait().await
    }

    /// The owner: puts the pending edits in `settings`, and sets the settings they replace
    /// aside on the desk; `false` (and nothing changed) if no edits are pending.
    pub fn take_edits(&self, settings: &mut Settings) -> bool {
        self.pending.lock(|cell| {
            let mut slot = cell.borrow_mut();
            match core::mem::replace(&mut *slot, Slot::Empty) {
                Slot::Edits(edits) => {
                    *slot = Slot::SetAside(core::mem::replace(settings, edits));
                    true
                }
                other => {
                    *slot = other;
                    false
                }
            }
        })
    }

    /// The owner, after [`Desk::take_edits`]: whether the edits now in `settings` were made
    /// on other saved settings than the owner's set aside, which it saved since they were
    /// copied. Saved, they would undo that save: answer them [`Refused::Stale`].
    pub fn edits_stale(&self, settings: &Settings) -> bool {
        self.pending.lock(
            |cell| matches!(&*cell.borrow(), Slot::SetAside(own) if !own.same_saved(settings)),
        )
    }

    /// The owner: answers the request whose edits it took. A refused save puts the settings
    /// set aside back in `settings`; a save drops them, and this returns their changes that
    /// were not saved (so lost), if any.
    pub fn answer(&self, settings: &mut Settings, result: Result<Saved, Refused>) -> Unsaved {
        let lost = self.pending.lock(|cell| {
            let slot = core::mem::replace(&mut *cell.borrow_mut(), Slot::Empty);
            match (slot, &result) {
                (Slot::SetAside(own), Err(_)) => {
                    *settings = own;
                    Unsaved::NONE
                }
                (Slot::SetAside(own), Ok(_)) => own.unsaved_changes(),
                _ => Unsaved::NONE,
            }
        });
        self.replies.signal(result);
        lost
    }
}
