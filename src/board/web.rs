//! The status and settings page's HTTP server, the same on every board: a few tasks of
//! their own, each with its own socket and buffers, serving the library's [`web`] module
//! on port 80 over picoserve.
//!
//! | request | answer |
//! |---|---|
//! | `GET /` | [`web::INDEX_HTML`] |
//! | `GET /api/status` | [`web::write_status`] of the application's latest snapshot, never cached |
//! | `GET /settings` | [`web::write_settings_page`] of the console's settings |
//! | `POST /settings` | [`web::post_settings`], then the settings page with its message and status |
//!
//! Any other path is 404, another method on these paths 405, a malformed request 400, a
//! form longer than [`web::FORM_MAX`] 413, a settings request that waited too long for
//! another 503; the task then serves the next connection. Settings requests are served one
//! at a time, and the forms are saved by a task of their own, so that the settings' copies
//! take RAM once rather than in every server task.
//!
//! Nothing here holds the executor that the buttons and the commands share: the tasks only
//! wait on their sockets and the settings' owner, each answer is written a socket buffer at
//! a time, and every read and write has a timeout, so a slow or silent client holds one
//! task (not the others) for seconds at most. Each connection carries one request (no
//! keep-alive), so that a browser cannot keep every task to itself.

use core::fmt;

use embassy_executor::{SpawnError, Spawner};
use embassy_net::Stack;
use embassy_net::tcp::TcpSocket;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant, Timer, with_timeout};
use picoserve::io::{Read, ReadExactError, Write};
use picoserve::request::Request;
use picoserve::response::{Content, IntoResponse, Response, ResponseWriter, StatusCode};
use picoserve::routing::{PathRouter, RequestHandlerService, get, get_service};
use picoserve::{ResponseSent, Router, Timeouts};
use x30_panel::settings::Settings;
use x30_panel::web::{self, FORM_MAX, Posted};

use super::glue::{desk, shared};

/// The page's TCP port.
pub const PORT: u16 = 80;

/// Server tasks, and so connections served at once: a page load or form, the status poll
/// of a page already open, and a connection that a browser opens ahead of need (Chromium
/// does, and with two tasks a form's POST then finds none free). A connection beyond them
/// is refused by the stack until a task is free again. Each task costs 6.4 KiB of RAM: its
/// socket's buffers, picoserve's request buffer and its future.
pub const TASKS: usize = 3;

/// Received bytes not yet read: a request line and headers arrive in a packet or two.
const RX_BUFFER: usize = 1024;
/// Written bytes not yet acknowledged: an answer goes out this much at a time.
const TX_BUFFER: usize = 1536;
/// A request's line and headers (a settings form goes on into [`FORM`]). A browser's
/// request headers to an address without cookies take well under 1 KiB; longer ones are
/// answered 400.
const HTTP_BUFFER: usize = 1024;

/// A connection that neither the client nor the stack's timeouts end this long is reset:
/// a backstop behind picoserve's own timeouts.
const SOCKET_TIMEOUT: Duration = Duration::from_secs(10);

/// How long a failed accept waits before the next; accepting on a fresh socket fails only
/// through a bug, which must not spin the executor.
const ACCEPT_RETRY: Duration = Duration::from_secs(1);

/// One request per connection, and short timeouts: a browser sends its request at once,
/// and a connection it opens ahead of need must not keep a task idle for long.
static CONFIG: picoserve::Config = picoserve::Config::new(Timeouts {
    start_read_request: Duration::from_secs(1),
    persistent_start_read_request: Duration::from_secs(1),
    read_request: Duration::from_secs(3),
    write: Duration::from_secs(2),
})
.close_connection_after_response();

/// Starts the server tasks on `stack`, and the task that saves their forms; call once.
pub fn spawn(spawner: Spawner, stack: Stack<'static>) -> Result<(), SpawnError> {
    spawner.spawn(settings_task()?);
    for _ in 0..TASKS {
        spawner.spawn(server_task(stack)?);
    }
    Ok(())
}

/// Accepts connections on [`PORT`] and serves each, forever.
#[embassy_executor::task(pool_size = TASKS)]
async fn server_task(stack: Stack<'static>) -> ! {
    let mut rx = [0; RX_BUFFER];
    let mut tx = [0; TX_BUFFER];
    let mut http = [0; HTTP_BUFFER];
    let app = router();
    loop {
        // A fresh socket per connection: dropping the last one released it whatever state
        // it was left in.
        let mut socket = TcpSocket::new(stack, &mut rx, &mut tx);
        socket.set_timeout(Some(SOCKET_TIMEOUT));
        if let Err(e) = socket.accept(PORT).await {
            board_log!(warn, "web: cannot accept on port {}: {:?}", PORT, e);
            Timer::after(ACCEPT_RETRY).await;
            continue;
        }
        // A failed connection (reset, timeout, malformed request) was answered or aborted
        // by picoserve; nothing is left to do about it but serve the next.
        let _ = picoserve::Server::new(&app, &CONFIG, &mut http)
            .serve(socket)
            .await;
    }
}

/// The page's routes. The answers built from the panel's state are services rather than
/// handler functions: they keep that state in their own future and lend it to the body,
/// where a handler's answer would be moved through each of picoserve's layers and take
/// room in each.
fn router() -> Router<impl PathRouter> {
    Router::new()
        .route(
            "/",
            get(|| async { Response::ok(web::INDEX_HTML).with_content_type(HTML) }),
        )
        .route("/api/status", get_service(Status))
        .route(
            "/settings",
            get_service(SettingsPage).post_service(PostSettings),
        )
}

/// The `Content-Type` of the pages.
const HTML: &str = "text/html; charset=utf-8";
/// The `Content-Type` of `/api/status`.
const JSON: &str = "application/json";

/// `GET /api/status`: the application's latest snapshot.
struct Status;

impl RequestHandlerService for Status {
    async fn call_request_handler_service<R: Read, W: ResponseWriter<Error = R::Error>>(
        &self,
        _state: &(),
        _path_parameters: (),
        request: Request<'_, R>,
        response_writer: W,
    ) -> Result<ResponseSent, W::Error> {
        let snapshot = shared().snapshot();
        let now = Instant::now();
        let body = |out: &mut fmt::Formatter<'_>| web::write_status(snapshot.as_ref(), now, out);
        answer(request, response_writer, StatusCode::OK, JSON, body).await
    }
}

/// The settings the page shows (none before the console runs), copied from the desk for
/// each settings request. One settings request is served at a time, holding this: they are
/// rare, and a copy of the settings in each server task would cost RAM the board does not
/// have. A vector of at most one rather than an `Option`: it starts as zeros, in `.bss`,
/// where a `None` would be a flash image of the whole size.
static SHOWN: Mutex<CriticalSectionRawMutex, heapless::Vec<Settings, 1>> =
    Mutex::new(heapless::Vec::new());

/// How long a settings request waits for the one before it; then it is answered 503.
const SETTINGS_WAIT: Duration = Duration::from_secs(5);

/// The form being saved, from the server task that read it to [`settings_task`].
static FORM: Mutex<CriticalSectionRawMutex, heapless::Vec<u8, FORM_MAX>> =
    Mutex::new(heapless::Vec::new());
/// A form is in [`FORM`], for [`settings_task`] to save.
static FORM_READY: Signal<CriticalSectionRawMutex, ()> = Signal::new();
/// What saving it came to.
static POSTED: Signal<CriticalSectionRawMutex, Posted> = Signal::new();

/// Saves the forms the server tasks read, one at a time: [`web::post_settings`] (and the
/// settings it edits) runs here once, rather than in every server task.
#[embassy_executor::task]
async fn settings_task() -> ! {
    loop {
        FORM_READY.wait().await;
        let form = FORM.lock().await;
        let posted = web::post_settings(desk(), &form).await;
        drop(form);
        POSTED.signal(posted);
    }
}

/// `GET /settings`: the settings page.
struct SettingsPage;

impl RequestHandlerService for SettingsPage {
    async fn call_request_handler_service<R: Read, W: ResponseWriter<Error = R::Error>>(
        &self,
        _state: &(),
        _path_parameters: (),
        request: Request<'_, R>,
        response_writer: W,
    ) -> Result<ResponseSent, W::Error> {
        let Ok(mut shown) = with_timeout(SETTINGS_WAIT, SHOWN.lock()).await else {
            return busy(request, response_writer).await;
        };
        show_settings(&mut shown);
        settings_page(request, response_writer, shown.first(), None).await
    }
}

/// `POST /settings`: reads the form (at most [`FORM_MAX`] bytes), has it saved, and
/// answers with the settings page, its message and its status.
struct PostSettings;

impl RequestHandlerService for PostSettings {
    async fn call_request_handler_service<R: Read, W: ResponseWriter<Error = R::Error>>(
        &self,
        _state: &(),
        _path_parameters: (),
        mut request: Request<'_, R>,
        response_writer: W,
    ) -> Result<ResponseSent, W::Error> {
        let Ok(mut shown) = with_timeout(SETTINGS_WAIT, SHOWN.lock()).await else {
            return busy(request, response_writer).await;
        };
        let body = request.body_connection.body();
        let length = body.content_length();
        let mut read_whole = false;
        let posted = if length > FORM_MAX {
            // Not read: picoserve discards it (within its read timeout) or closes.
            message(413, "The form is too long: nothing was changed.")
        } else {
            // Holding `SHOWN`, this task is the only one to fill the form; the settings
            // task takes it only once told to.
            let mut form = FORM.lock().await;
            form.clear();
            // Within the capacity: `length` is at most FORM_MAX.
            let _ = form.resize(length, 0);
            let read = body.reader().read_exact(&mut form).await;
            drop(form);
            match read {
                Ok(()) => {
                    read_whole = true;
                    POSTED.reset();
                    FORM_READY.signal(());
                    POSTED.wait().await
                }
                Err(ReadExactError::UnexpectedEof) => {
                    message(400, "The form did not arrive whole: nothing was changed.")
                }
                Err(ReadExactError::Other(e)) => return Err(e),
            }
        };
        show_settings(&mut shown);
        // The settings task is done with the form, and no other POST fills it while this
        // one holds `SHOWN`: the page shows what was typed if it was not saved.
        let form = FORM.lock().await;
        let typed = if read_whole { &form[..] } else { &[] };
        settings_page(
            request,
            response_writer,
            shown.first(),
            Some((&posted, typed)),
        )
        .await
    }
}

/// Puts the console's settings, as they are now, in `shown`.
fn show_settings(shown: &mut heapless::Vec<Settings, 1>) {
    shown.clear();
    if let Some(settings) = desk().settings() {
        // Room for one, and `shown` was just emptied.
        let _ = shown.push(settings);
    }
}

/// Answers `request` with the settings page for `settings`, and after a POST its message
/// and status, and the form it posted.
async fn settings_page<R: Read, W: ResponseWriter<Error = R::Error>>(
    request: Request<'_, R>,
    response_writer: W,
    settings: Option<&Settings>,
    posted: Option<(&Posted, &[u8])>,
) -> Result<ResponseSent, W::Error> {
    let (posted, form) = posted.map_or((None, &[][..]), |(posted, form)| (Some(posted), form));
    let status = posted.map_or(StatusCode::OK, |p| StatusCode::new(p.status));
    let body = |out: &mut fmt::Formatter<'_>| web::write_settings_page(settings, posted, form, out);
    answer(request, response_writer, status, HTML, body).await
}

/// Answers a settings request that waited too long for the one before it: 503, and the
/// settings page's own message.
async fn busy<R: Read, W: ResponseWriter<Error = R::Error>>(
    request: Request<'_, R>,
    response_writer: W,
) -> Result<ResponseSent, W::Error> {
    let posted = message(503, "Another settings request is under way: try again.");
    settings_page(request, response_writer, None, Some((&posted, &[]))).await
}

/// A settings page message with its status.
fn message(status: u16, text: &str) -> Posted {
    let mut message = heapless::String::new();
    // Each message here fits the string; a longer one would only be cut short.
    let _ = message.push_str(text);
    Posted { status, message }
}

/// Answers `request` with `status` and the body `write` writes, never cached: it shows
/// the panel as it is now.
async fn answer<R: Read, W: ResponseWriter<Error = R::Error>>(
    request: Request<'_, R>,
    response_writer: W,
    status: StatusCode,
    content_type: &'static str,
    write: impl Fn(&mut fmt::Formatter<'_>) -> fmt::Result,
) -> Result<ResponseSent, W::Error> {
    let connection = request.body_connection.finalize().await?;
    Response::new(status, Rendered::new(content_type, write))
        .with_header("Cache-Control", "no-store")
        .write_to(connection, response_writer)
        .await
}

/// A body that a [`web`] function writes: measured once for its `Content-Length`, then
/// written straight into the socket's buffer, again for each buffer-full (picoserve
/// formats it anew and skips what went out before). It must therefore come out the same
/// each time: everything it shows is taken before, never read while writing.
struct Rendered<F> {
    /// Its `Content-Type`.
    content_type: &'static str,
    /// Writes it.
    write: F,
}

impl<F: Fn(&mut fmt::Formatter<'_>) -> fmt::Result> Rendered<F> {
    /// A body of `content_type` that `write` writes.
    fn new(content_type: &'static str, write: F) -> Self {
        Self {
            content_type,
            write,
        }
    }
}

impl<F: Fn(&mut fmt::Formatter<'_>) -> fmt::Result> fmt::Display for Rendered<F> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (self.write)(f)
    }
}

/// Counts the bytes written to it.
struct Length(usize);

impl fmt::Write for Length {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.0 += s.len();
        Ok(())
    }
}

impl<F: Fn(&mut fmt::Formatter<'_>) -> fmt::Result> Content for Rendered<F> {
    fn content_type(&self) -> &'static str {
        self.content_type
    }

    fn content_length(&self) -> usize {
        let mut length = Length(0);
        // A body that cannot be written is sent empty (picoserve skips it too).
        match fmt::write(&mut length, format_args!("{self}")) {
            Ok(()) => length.0,
            Err(fmt::Error) => 0,
        }
    }

    async fn write_content<W: Write>(self, mut writer: W) -> Result<(), W::Error> {
        writer.write_fmt(format_args!("{self}")).await
    }
}
