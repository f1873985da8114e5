//! The settings form: what a POST to `/settings` does.
//!
//! The body is `application/x-www-form-urlencoded`: `pin=1234&speed-forward=0.8&…`, each
//! field a setting's name ([`Key::name`], any case) or `pin`, `+` for a space and `%XX` for
//! any byte, the whole at most [`FORM_MAX`] bytes. The rules:
//!
//! 1. A body longer than [`FORM_MAX`] is refused with 413; one with a bad `%`-escape, text
//!    that is not UTF-8, a value longer than [`MAX_VALUE`], a field that is no setting, or a
//!    field given twice with 400, naming the problem. Nothing is saved.
//! 2. `pin` must be the saved `web-pin`, compared without stopping at the first difference;
//!    missing or wrong is 403 "PIN wrong", answered only after [`PIN_PENALTY`] with every
//!    other PIN check waiting behind it, so a 4-digit PIN takes hours to guess. With no PIN
//!    saved, the page is read-only: 403, and how to set one on the console.
//! 3. The form starts from the saved settings (changes typed on the console and not saved
//!    are dropped, as the console tells). The page's form carries `saved`, the
//!    [`Settings::saved_stamp`] of the settings it showed: if they have been saved over
//!    since (on the console), the form is refused with 409 and nothing saved, since its
//!    fields would put the values it showed back. A field equal to the value the page
//!    showed changes nothing; an empty field returns its setting to the default (`unset`); any other value
//!    is set, and an invalid one is refused with 400 and what the setting allows, nothing
//!    saved. A setting not in the form stays as saved. `web-pin` shows as `****`, which
//!    keeps the PIN.
//! 4. The settings' owner saves the result with the console's checks: 200 and the keys
//!    saved; 409 when nothing changed, the edits conflict, they do not fit the store, or the
//!    panel is busy (a stop going out, a motion button held, a task running); 500 when the
//!    flash failed; 503 when the settings are not available yet.

use core::fmt::{self, Write as _};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex;
use embassy_time::{Duration, Timer};

use crate::config::WebPin;
use crate::settings::desk::{Desk, Refused, Saved};
use crate::settings::{Invalid, Key, Keys, MAX_VALUE, Settings};

/// Longest settings form body accepted, bytes; a longer one is refused with 413.
pub const FORM_MAX: usize = 2048;

/// How long a wrong PIN's answer waits, holding every other PIN check back meanwhile.
pub const PIN_PENALTY: Duration = Duration::from_secs(1);

/// What the page shows for a PIN that is set, and what keeps it when posted back.
pub const MASKED_PIN: &str = "****";

/// The field that carries the PIN.
const PIN_FIELD: &str = "pin";

/// The field that carries the [`Settings::saved_stamp`] of the settings the page showed.
pub const SAVED_FIELD: &str = "saved";

/// Longest field name decoded: longer than any setting's.
const NAME_MAX: usize = 32;

/// Most bytes of [`Posted::message`].
pub const MESSAGE_MAX: usize = 256;

/// One PIN check at a time, so that waiting out a wrong PIN slows every guess.
static PIN_TURN: Mutex<CriticalSectionRawMutex, ()> = Mutex::new(());

/// What a POST of the settings form came to: the HTTP status and a message for the page.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Posted {
    /// 200 saved, 400 malformed or invalid, 403 PIN missing or wrong, 409 refused now
    /// (busy, nothing changed, conflict), 413 too long, 500 flash failed, 503 settings not
    /// available.
    pub status: u16,
    /// What the page tells the person.
    pub message: heapless::String<MESSAGE_MAX>,
}

impl Posted {
    /// A status and its message, cut short if it is longer than [`MESSAGE_MAX`].
    fn new(status: u16, message: fmt::Arguments<'_>) -> Self {
        let mut posted = Self {
            status,
            message: heapless::String::new(),
        };
        let _ = posted.writer().write_fmt(message);
        posted
    }

    /// Writes more of the message, cutting it short rather than failing when it is full.
    fn writer(&mut self) -> Clip<'_> {
        Clip {
            text: &mut self.message,
            full: false,
        }
    }

    /// What the page says of a save: the keys saved, those that wait for a reboot, and
    /// whether the panel reconnects.
    fn saved(saved: &Saved) -> Self {
        let mut posted = Self::new(200, format_args!("saved "));
        let mut message = posted.writer();
        let _ = write!(message, "{}", saved.keys);
        let mut later = saved.keys.iter().filter(|k| k.needs_reboot()).peekable();
        if later.peek().is_some() {
            let _ = message.write_str("; after a reboot:");
            for key in later {
                let _ = write!(message, " {}", key.name());
            }
        }
        if saved.moved {
            let _ = message.write_str("; the panel reconnects to the new robot");
        }
        posted
    }
}

/// Writes into a message until it is full, then drops the rest.
struct Clip<'a> {
    /// The message.
    text: &'a mut heapless::String<MESSAGE_MAX>,
    /// Whether something did not fit: nothing more is written after it.
    full: bool,
}

impl fmt::Write for Clip<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for c in s.chars() {
            self.full = self.full || self.text.push(c).is_err();
        }
        Ok(())
    }
}

/// Why a form was not saved.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Problem {
    /// The body is longer than [`FORM_MAX`].
    TooLong,
    /// A field's name could not be decoded.
    Name(Malformed),
    /// A field that is no setting, as decoded.
    Unknown(heapless::String<NAME_MAX>),
    /// A field's value could not be decoded.
    Value(Field, Malformed),
    /// A field given twice.
    Twice(Field),
    /// The settings' owner has not published them yet.
    NotAvailable,
    /// No PIN is saved: the page is read-only.
    ReadOnly,
    /// The PIN is missing or wrong.
    PinWrong,
    /// A value not valid for its setting, and its start as typed.
    Invalid(Invalid, TypedStart),
    /// The settings' owner did not save.
    Refused(Refused),
}

impl From<Refused> for Problem {
    fn from(refused: Refused) -> Self {
        Self::Refused(refused)
    }
}

impl Problem {
    /// The HTTP status that tells it.
    fn status(&self) -> u16 {
        match self {
            Self::TooLong => 413,
            Self::Name(_) | Self::Unknown(_) | Self::Value(..) | Self::Twice(_) => 400,
            Self::Invalid(..) => 400,
            Self::ReadOnly | Self::PinWrong => 403,
            Self::NotAvailable | Self::Refused(Refused::NoOwner) => 503,
            Self::Refused(
                Refused::NothingChanged
                | Refused::Conflict(_)
                | Refused::Busy(_)
                | Refused::TooLarge
                | Refused::Stale,
            ) => 409,
            Self::Refused(_) => 500,
        }
    }
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooLong => write!(f, "the form is longer than {FORM_MAX} bytes"),
            Self::Name(malformed) => write!(f, "a field's name {malformed}"),
            Self::Unknown(name) => write!(f, "no setting `{name}` (is the page outdated?)"),
            Self::Value(field, malformed) => write!(f, "{}: the value {malformed}", field.name()),
            Self::Twice(field) => write!(f, "`{}` is in the form twice", field.name()),
            Self::NotAvailable => f.write_str("the settings are not available yet"),
            Self::ReadOnly => f.write_str(
                "this page is read-only: set a PIN on the serial console \
                 (`set web-pin 1234`, then `save`) to change settings here",
            ),
            Self::PinWrong => f.write_str("PIN wrong"),
            Self::Invalid(Invalid(key), typed) => write!(
                f,
                "{}: `{typed}` is not valid: expected {}",
                key.name(),
                key.allowed()
            ),
            // Says itself that nothing was saved.
            Self::Refused(refused) => return write!(f, "{refused}"),
        }?;
        f.write_str("; nothing saved")
    }
}

/// Applies a settings form (`application/x-www-form-urlencoded`: `pin=…&KEY=VALUE…`) and
/// has the settings' owner save it through `desk`.
pub async fn post_settings(desk: &Desk, body: &[u8]) -> Posted {
    match apply(desk, body).await {
        Ok(saved) => Posted::saved(&saved),
        Err(problem) => Posted::new(problem.status(), format_args!("{problem}")),
    }
}

/// [`post_settings`]: what was saved, or why nothing was.
async fn apply(desk: &Desk, body: &[u8]) -> Result<Saved, Problem> {
    if body.len() > FORM_MAX {
        return Err(Problem::TooLong);
    }
    let (pin, shown) = check_fields(body)?;
    // Only the PIN is held across the PIN check's wait, not a copy of the settings (a few
    // KiB in this future, which the board keeps in static RAM).
    let saved_pin = desk
        .settings()
        .ok_or(Problem::NotAvailable)?
        .config()
        .web_pin;
    check_pin(saved_pin, pin).await?;
    desk.save_with(|settings| {
        if shown.is_some_and(|shown| shown != settings.saved_stamp()) {
            return Err(Problem::Refused(Refused::Stale));
        }
        settings.revert();
        for field in fields(body) {
            let (mut name, mut value) = ([0; NAME_MAX], [0; MAX_VALUE]);
            if let (Field::Key(key), text) = field.decode(&mut name, &mut value)? {
                change(settings, key, text.trim())?;
            }
        }
        Ok(())
    })
    .await
}

/// Checks every field of `body` (escapes, names, no field twice, a `saved` stamp that is a
/// number) before anything changes; the `pin` field's text, still encoded, and the `saved`
/// stamp, if there are.
fn check_fields(body: &[u8]) -> Result<(Option<&[u8]>, Option<u32>), Problem> {
    let (mut seen, mut pin, mut shown) = (Keys::EMPTY, None, None);
    for field in fields(body) {
        let (mut name, mut value) = ([0; NAME_MAX], [0; MAX_VALUE]);
        let (kind, text) = field.decode(&mut name, &mut value)?;
        let twice = match kind {
            Field::Pin => pin.replace(field.value).is_some(),
            Field::Saved => {
                let stamp = text
                    .parse()
                    .map_err(|_| Problem::Value(kind, Malformed::Stamp))?;
                shown.replace(stamp).is_some()
            }
            Field::Key(key) => {
                let twice = seen.contains(key);
                seen.insert(key);
                twice
            }
        };
        if twice {
            return Err(Problem::Twice(kind));
        }
    }
    Ok((pin, shown))
}

/// The `saved` stamp a posted `form` carries, if it carries a valid one.
pub(super) fn posted_stamp(form: &[u8]) -> Option<u32> {
    check_fields(form).ok()?.1
}

/// Checks the form's `pin` (still encoded) against the saved one.
async fn check_pin(saved: Option<WebPin>, pin: Option<&[u8]>) -> Result<(), Problem> {
    let saved = saved.ok_or(Problem::ReadOnly)?;
    let _turn = PIN_TURN.lock().await;
    if pin.is_some_and(|pin| is_pin(pin, &saved)) {
        return Ok(());
    }
    Timer::after(PIN_PENALTY).await;
    Err(Problem::PinWrong)
}

/// Whether the form's `pin` (still encoded) is `saved`.
fn is_pin(pin: &[u8], saved: &WebPin) -> bool {
    let mut given = [0; MAX_VALUE];
    decode(pin, &mut given)
        .is_ok_and(|given| same_secret(given.as_bytes(), saved.as_str().as_bytes()))
}

/// Whether `given` is `secret`, looking at every byte given whatever the first difference.
fn same_secret(given: &[u8], secret: &[u8]) -> bool {
    let mut differ = u8::from(given.len() != secret.len());
    for (i, &byte) in given.iter().enumerate() {
        differ |= byte ^ secret.get(i).copied().unwrap_or(0);
    }
    differ == 0
}

/// Applies the form's `text` for `key` to `settings` (see the module's rules).
fn change(settings: &mut Settings, key: Key, text: &str) -> Result<(), Problem> {
    let mut shown = heapless::String::<MAX_VALUE>::new();
    let _ = key.write(settings.edited(), &mut shown);
    let masked = key == Key::WebPin && settings.edited().web_pin.is_some() && text == MASKED_PIN;
    if text == shown.as_str() || masked {
        return Ok(());
    }
    if text.is_empty() {
        settings.unset(key);
        return Ok(());
    }
    settings
        .set(key, text)
        .map_err(|invalid| Problem::Invalid(invalid, TypedStart::of(text)))
}

/// The start of a value as typed, for a message about it: [`TYPED_SHOWN`] bytes at most,
/// cut at a character and marked `…` when cut.
#[derive(Debug, Clone, PartialEq, Eq)]
struct TypedStart(heapless::String<{ TYPED_SHOWN + '…'.len_utf8() }>);

/// Most bytes of a typed value a message quotes.
const TYPED_SHOWN: usize = 32;

impl TypedStart {
    /// The start of `text`.
    fn of(text: &str) -> Self {
        let mut start = heapless::String::new();
        for c in text.chars() {
            if start.len() + c.len_utf8() > TYPED_SHOWN {
                // The room for the mark is kept.
                let _ = start.push('…');
                break;
            }
            let _ = start.push(c);
        }
        Self(start)
    }
}

impl fmt::Display for TypedStart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The value of `key`'s field in `form`, decoded into `value`; `None` when the form has no
/// such field or it cannot be decoded.
pub(super) fn typed_value<'v>(
    form: &[u8],
    key: Key,
    value: &'v mut [u8; MAX_VALUE],
) -> Option<&'v str> {
    let field = fields(form).find(|field| {
        let mut name = [0; NAME_MAX];
        field.field(&mut name) == Ok(Field::Key(key))
    })?;
    decode(field.value, value).ok()
}

/// What a form field is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Field {
    /// The PIN.
    Pin,
    /// The stamp of the settings the page showed.
    Saved,
    /// A setting.
    Key(Key),
}

impl Field {
    /// The field's name in the form.
    fn name(self) -> &'static str {
        match self {
            Self::Pin => PIN_FIELD,
            Self::Saved => SAVED_FIELD,
            Self::Key(key) => key.name(),
        }
    }
}

/// One `name=value` field of a form, still encoded.
#[derive(Debug, Clone, Copy)]
struct Encoded<'a> {
    /// The name.
    name: &'a [u8],
    /// The value: empty when the field has no `=`.
    value: &'a [u8],
}

/// The fields of `body`, empty ones (`a=1&&b=2`) left out.
fn fields(body: &[u8]) -> impl Iterator<Item = Encoded<'_>> {
    body.split(|&b| b == b'&')
        .filter(|field| !field.is_empty())
        .map(|field| {
            let mut parts = field.splitn(2, |&b| b == b'=');
            Encoded {
                name: parts.next().unwrap_or_default(),
                value: parts.next().unwrap_or_default(),
            }
        })
}

impl Encoded<'_> {
    /// What the field is and its value, decoded into `name` and `value`.
    fn decode<'v>(
        &self,
        name: &mut [u8; NAME_MAX],
        value: &'v mut [u8; MAX_VALUE],
    ) -> Result<(Field, &'v str), Problem> {
        let field = self.field(name)?;
        let value = decode(self.value, value).map_err(|e| Problem::Value(field, e))?;
        Ok((field, value))
    }

    /// What the field is, its name decoded into `name`.
    fn field(&self, name: &mut [u8; NAME_MAX]) -> Result<Field, Problem> {
        let name = decode(self.name, name).map_err(Problem::Name)?;
        if name == PIN_FIELD {
            return Ok(Field::Pin);
        }
        if name == SAVED_FIELD {
            return Ok(Field::Saved);
        }
        let mut unknown = heapless::String::new();
        Ok(Field::Key(Key::from_name(name).ok_or_else(|| {
            // The name was decoded into as many bytes as this holds.
            let _ = unknown.push_str(name);
            Problem::Unknown(unknown)
        })?))
    }
}

/// Why a field's text could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Malformed {
    /// A `%` not followed by two hex digits.
    Escape,
    /// Not UTF-8 once decoded.
    NotUtf8,
    /// Longer than the buffer.
    TooLong,
    /// Not a number, where the field holds one (`saved`).
    Stamp,
}

impl fmt::Display for Malformed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Escape => "has a `%` not followed by two hex digits",
            Self::NotUtf8 => "is not UTF-8 text",
            Self::TooLong => "is too long",
            Self::Stamp => "is not a number (is the page outdated?)",
        })
    }
}

/// Decodes `+` (a space) and `%XX` (a byte) of `text` into `buf`.
fn decode<'b>(text: &[u8], buf: &'b mut [u8]) -> Result<&'b str, Malformed> {
    let mut len = 0;
    let mut bytes = text.iter();
    while let Some(&byte) = bytes.next() {
        let byte = match byte {
            b'+' => b' ',
            b'%' => match (bytes.next().and_then(hex), bytes.next().and_then(hex)) {
                (Some(high), Some(low)) => (high << 4) | low,
                _ => return Err(Malformed::Escape),
            },
            byte => byte,
        };
        *buf.get_mut(len).ok_or(Malformed::TooLong)? = byte;
        len += 1;
    }
    core::str::from_utf8(buf.get(..len).unwrap_or_default()).map_err(|_| Malformed::NotUtf8)
}

/// The value of a hex digit.
fn hex(digit: &u8) -> Option<u8> {
    char::from(*digit).to_digit(16).map(|d| d as u8)
}
