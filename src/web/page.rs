//! The `/settings` page: every setting with its value, where it comes from and what it
//! allows; a form to change them when a PIN is set, else how to set one.

use core::fmt::{self, Write};

use super::form::{
    FORM_MAX, MASKED_PIN, MESSAGE_MAX, Posted, SAVED_FIELD, posted_stamp, typed_value,
};
use super::{HEAD_LEN, escape, escaped_len, head};
use crate::proto::xml::number::F32_TEXT_MAX;
use crate::settings::text::{MAX_LIGHT_PRESETS, MAX_PIN_DIGITS};
use crate::settings::{Key, MAX_VALUE, Settings, Syntax};

/// Longest page [`write_settings_page`] writes, bytes: every value at the longest text its
/// syntax allows (text that needs no escaping: digits, letters and `.:,/-`), a message of
/// [`MESSAGE_MAX`] escaped at worst, a refused form's values (at most [`FORM_MAX`] bytes
/// together) escaped at worst, and the page around them.
pub const SETTINGS_PAGE_MAX: usize = {
    let mut total = HEAD_LEN + TITLE.len() + FRAME_MAX + ESCAPED * MESSAGE_MAX + ESCAPED * FORM_MAX;
    let mut keys = Key::ALL;
    while let [key, rest @ ..] = keys {
        total +=
            ROW_MAX + 4 * key.name().len() + value_max(key.syntax()) + escaped_len(key.allowed());
        keys = rest;
    }
    total
};

/// Longest text one character escapes to (`&quot;`).
const ESCAPED: usize = 6;

/// The markup of one setting's row, without its name, value and hint.
const ROW_MAX: usize = 160;

/// The page's text besides the head, the rows and the message: headings, notes, the PIN
/// field and the keys changed on the console and not saved.
const FRAME_MAX: usize = 1536;

/// Longest text a value of `syntax` is written as.
const fn value_max(syntax: Syntax) -> usize {
    // "-2147483648", and a float's longest text after a comma.
    const INT: usize = 11;
    const FLOAT: usize = F32_TEXT_MAX;
    match syntax {
        // 255.255.255.255:65535
        Syntax::Robot => 21,
        Syntax::Switch => 1,
        // 255.255.255.255/32
        Syntax::Cidr => 18,
        Syntax::Ipv4 => 15,
        Syntax::Speed { .. } => FLOAT,
        // FFFFFF:100:breathing, comma-separated
        Syntax::Lights => MAX_LIGHT_PRESETS * 21,
        // point,map,x,y,z,yaw
        Syntax::Dock => 2 * INT + 1 + 4 * (1 + FLOAT),
        // A u64 of milliseconds.
        Syntax::Millis { .. } => 20,
        Syntax::EstopInput => 2,
        Syntax::Pin => MAX_PIN_DIGITS,
    }
}

/// The page's title, after the head all pages share.
const TITLE: &str = "<title>X30 panel settings</title>";

/// Writes the `/settings` page: the settings table, the form when a PIN is set (else how to
/// set one), and `posted`'s message after a POST. When that POST was not saved, its form
/// `posted_form` fills the fields it has, so that nothing typed is lost (but a new PIN,
/// which the page never shows).
pub fn write_settings_page(
    settings: Option<&Settings>,
    posted: Option<&Posted>,
    posted_form: &[u8],
    out: &mut impl fmt::Write,
) -> fmt::Result {
    page(settings, posted, posted_form, out)
}

/// [`write_settings_page`], one copy whatever the writer.
fn page(
    settings: Option<&Settings>,
    posted: Option<&Posted>,
    posted_form: &[u8],
    out: &mut dyn Write,
) -> fmt::Result {
    // A refused form's fields come back as they were typed, unless the settings it was
    // made on have been saved over since: then the page shows them as they are now.
    let stamp = settings.map(Settings::saved_stamp);
    let refused_form = match posted {
        Some(posted)
            if posted.status != 200
                && posted_stamp(posted_form).is_none_or(|shown| Some(shown) == stamp) =>
        {
            posted_form
        }
        _ => &[],
    };
    out.write_str(head())?;
    out.write_str(TITLE)?;
    out.write_str("<h1>Settings</h1><p><a href=\"/\">Status</a></p>")?;
    if let Some(posted) = posted {
        let class = if posted.status == 200 { "ok" } else { "err" };
        write!(out, "<p id=posted class={class}>")?;
        escape(out, &posted.message)?;
        out.write_str("</p>")?;
    }
    let Some(settings) = settings else {
        return out.write_str(
            "<p class=note>The settings are not available yet: the panel is starting.</p>",
        );
    };
    // The page shows, and its form starts from, what is saved.
    let mut saved = settings.clone();
    saved.revert();
    let typed = settings.unsaved_changes();
    if !typed.is_empty() {
        out.write_str("<p class=note>Changed on the console and not saved: ")?;
        write!(out, "{typed}")?;
        out.write_str(". Saving here drops those changes.</p>")?;
    }
    let form = saved.config().web_pin.is_some();
    if form {
        out.write_str(
            "<form method=post action=\"/settings\"><p class=note>A field left as it is \
             keeps its value; an empty field returns it to its default.</p>",
        )?;
    } else {
        out.write_str(
            "<p class=note id=read-only>This page is read-only. To change settings here, set \
             a PIN on the serial console: <code>set web-pin 1234</code>, then \
             <code>save</code>.</p>",
        )?;
    }
    out.write_str("<div id=settings>")?;
    for &key in Key::ALL {
        row(out, &saved, key, form.then_some(refused_form))?;
    }
    out.write_str("</div>")?;
    if form {
        write!(
            out,
            "<input type=hidden name=\"{SAVED_FIELD}\" value=\"{}\">",
            saved.saved_stamp()
        )?;
        out.write_str(
            "<div class=row><label for=pin>PIN</label>\
             <input id=pin name=pin type=password inputmode=numeric autocomplete=off>\
             </div><p><button type=submit>Save</button></p></form>",
        )?;
    }
    out.write_str("</body></html>")
}

/// One setting: its name, whether it is the default, its value (in a field of the form
/// when there is one: as `typed` there, if it is), and what it allows.
fn row(out: &mut dyn Write, settings: &Settings, key: Key, form: Option<&[u8]>) -> fmt::Result {
    let name = key.name();
    let origin = if settings.is_overridden(key) {
        "set"
    } else {
        "default"
    };
    write!(
        out,
        "<div class=row><label for=\"k-{name}\">{name}</label> <small>[{origin}]</small><br>"
    )?;
    let mut value = heapless::String::<MAX_VALUE>::new();
    if key == Key::WebPin && settings.config().web_pin.is_some() {
        // The PIN guards the form: the page never shows it.
        let _ = value.push_str(MASKED_PIN);
    } else {
        // Every value fits: the store keeps no longer ones.
        let _ = key.write(settings.config(), &mut value);
    }
    if let Some(typed) = form {
        let mut typed_text = [0; MAX_VALUE];
        let shown = match typed_value(typed, key, &mut typed_text) {
            Some(text) if key != Key::WebPin => text,
            _ => &value,
        };
        write!(out, "<input id=\"k-{name}\" name=\"{name}\" value=\"")?;
        escape(out, shown)?;
        out.write_str("\">")?;
    } else {
        write!(out, "<code id=\"k-{name}\">")?;
        escape(out, &value)?;
        out.write_str("</code>")?;
    }
    out.write_str("<br><small>")?;
    escape(out, key.allowed())?;
    out.write_str("</small></div>")
}
