//! End to end: the board's web page. The QEMU firmware booted by x30-qemu with `--http`,
//! connected to an x30-sim running in this process; the page opened in headless Chromium
//! driven through chromedriver (WebDriver), and requests good and bad sent by hand.
//!
//! Without `qemu-system-arm` the tests print "SKIPPED: qemu-system-arm missing", and
//! without `chromium` or `chromedriver` the browser's prints "SKIPPED: chromium missing",
//! and return; CI has both (scripts/setup.sh installs them).
//!
//! With `X30_WEB_SCREENSHOT=FILE` the test also saves a PNG of the status page, as a phone
//! shows it, to FILE (scripts/web-screenshot.sh makes the README's).

mod common;

use std::io::{Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::*;
use fantoccini::error::CmdError;
use fantoccini::wd::TimeoutConfiguration;
use fantoccini::{Client, ClientBuilder, Locator};
use hyper_util::client::legacy::connect::HttpConnector;
use serde_json::json;
use x30_sim::Simulator;

/// Longest the whole session may last: boot, the browser, a settings save and two posts.
const WEB_SESSION: Duration = Duration::from_secs(180);

/// Longest chromedriver may take to listen, or to end the browser's session.
const DRIVER_START: Duration = Duration::from_secs(20);

/// Longest the page may take to show something the robot reported: the battery is polled
/// every 5 s and the page refreshes every second.
const PAGE_SHOWS: Duration = Duration::from_secs(25);

/// Longest a page load or a form submission may take.
const PAGE_LOAD: Duration = Duration::from_secs(30);

/// The window: a phone's, in CSS pixels.
const WINDOW: (u32, u32) = (430, 900);

/// The PIN the test sets on the console.
const PIN: &str = "2468";

/// Where a program is on PATH, if it is.
fn on_path(program: &str) -> Option<PathBuf> {
    std::env::split_paths(&std::env::var_os("PATH")?)
        .map(|dir| dir.join(program))
        .find(|path| path.is_file())
}

/// A free loopback port (free when asked; nothing else on this machine races for it).
fn free_port() -> u16 {
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0))
        .and_then(|listener| listener.local_addr())
        .expect("a free loopback port")
        .port()
}

/// chromedriver on a loopback port, killed when dropped.
struct Driver {
    child: Child,
    port: u16,
}

impl Driver {
    /// Starts `program` and waits until it listens.
    fn start(program: &Path) -> Self {
        let port = free_port();
        let child = Command::new(program)
            .arg(format!("--port={port}"))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts");
        let driver = Self { child, port };
        let deadline = Instant::now() + DRIVER_START;
        while TcpStream::connect((Ipv4Addr::LOCALHOST, port)).is_err() {
            assert!(
                Instant::now() < deadline,
                "chromedriver not listening after {DRIVER_START:?}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        driver
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A WebDriver session with headless Chromium at `chromium`, its profile in `profile`.
async fn browser(driver: &Driver, chromium: &Path, profile: &Path) -> Client {
    let (width, height) = WINDOW;
    let mut capabilities = serde_json::Map::new();
    capabilities.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": chromium,
            // This machine has no network but loopback: without the background-networking
            // flags Chromium keeps trying to reach its services and stalls.
            "args": [
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--hide-scrollbars",
                format!("--user-data-dir={}", profile.display()),
            ],
            // A phone's screen, exactly: a headless window's size would include its frame.
            "mobileEmulation": {
                "deviceMetrics": { "width": width, "height": height, "pixelRatio": 1 },
            },
        }),
    );
    let client = ClientBuilder::new(HttpConnector::new())
        .capabilities(capabilities)
        .connect(&format!("http://127.0.0.1:{}", driver.port))
        .await
        .expect("a WebDriver session with Chromium");
    client
        .update_timeouts(TimeoutConfiguration::new(
            Some(Duration::from_secs(10)),
            Some(PAGE_LOAD),
            Some(Duration::ZERO),
        ))
        .await
        .expect("timeouts set");
    client
}

/// Whether `text` shows the number `n` on its own (`73 %`, `73%`, not `173`).
fn shows_number(text: &str, n: i32) -> bool {
    text.split(|c: char| !c.is_ascii_digit())
        .any(|word| word == n.to_string())
}

/// What of an element [`shown_until`] reads.
#[derive(Clone, Copy)]
enum Shown {
    /// Its text, as the page shows it.
    Text,
    /// Its `class` attribute, which says how the page draws it (`stale`: greyed out).
    Class,
}

/// Polls the text of `css` until `accept` takes it or `limit` passes, doing `meanwhile`
/// before each look; the last text seen (or why there was none) as the error.
async fn text_until(
    client: &Client,
    css: &str,
    limit: Duration,
    meanwhile: impl FnMut(),
    accept: impl Fn(&str) -> bool,
) -> Result<String, String> {
    shown_until(client, css, Shown::Text, limit, meanwhile, accept).await
}

/// Polls `what` of `css` until `accept` takes it or `limit` passes, doing `meanwhile`
/// before each look; the last one seen (or why there was none) as the error.
async fn shown_until(
    client: &Client,
    css: &str,
    what: Shown,
    limit: Duration,
    mut meanwhile: impl FnMut(),
    accept: impl Fn(&str) -> bool,
) -> Result<String, String> {
    let deadline = Instant::now() + limit;
    loop {
        meanwhile();
        let last = match client.find(Locator::Css(css)).await {
            Ok(element) => match what {
                Shown::Text => element.text().await,
                Shown::Class => element.attr("class").await.map(Option::unwrap_or_default),
            },
            Err(e) => Err(e),
        };
        let last = match last {
            Ok(shown) if accept(&shown) => return Ok(shown),
            Ok(shown) => format!("{shown:?}"),
            Err(e) => e.to_string(),
        };
        if Instant::now() >= deadline {
            return Err(format!("{css} still shows {last} after {limit:?}"));
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// Waits until the page draws the section `css` as stale (greyed out) or, with `stale`
/// false, as current.
async fn stale_shows(client: &Client, css: &str, stale: bool) -> Result<String, String> {
    let is_stale = |class: &str| class.split(' ').any(|c| c == "stale");
    shown_until(
        client,
        css,
        Shown::Class,
        PAGE_SHOWS,
        || {},
        |class| is_stale(class) == stale,
    )
    .await
}

/// The text of the whole page.
async fn page_text(client: &Client) -> Result<String, CmdError> {
    client.find(Locator::Css("body")).await?.text().await
}

/// Keeps the simulated battery at `percent` (it drains while the robot stands).
fn hold_battery(sim: &Simulator, percent: f64) {
    sim.robot(|r| r.set_battery(percent));
}

/// Holds the simulated battery just above `percent` until the page shows that level.
async fn battery_level_shows(
    client: &Client,
    sim: &Simulator,
    percent: i32,
) -> Result<String, String> {
    text_until(
        client,
        "#battery-level",
        PAGE_SHOWS,
        || hold_battery(sim, f64::from(percent) + 0.4),
        |t| shows_number(t, percent),
    )
    .await
}

/// Waits until the page says the battery level it shows came from the answer of `message_type`.
async fn battery_source_shows(client: &Client, message_type: &str) -> Result<String, String> {
    text_until(
        client,
        "#battery-source",
        PAGE_SHOWS,
        || {},
        |t| t.contains(message_type),
    )
    .await
}

/// Fills the settings form with `speed-forward` and the PIN, submits it, and returns the
/// text of the page that answers.
async fn post_speed(client: &Client, speed: &str, pin: &str) -> Result<String, String> {
    let form = client
        .form(Locator::Css("form"))
        .await
        .map_err(fail("find the form"))?;
    form.set_by_name("speed-forward", speed)
        .await
        .map_err(fail("fill speed-forward"))?;
    form.set_by_name("pin", pin)
        .await
        .map_err(fail("fill the PIN"))?;
    // A click returns before the answer replaces the page: the mark tells the old page
    // from the new one.
    client
        .execute("window.x30Mark = 'form';", vec![])
        .await
        .map_err(fail("mark the form's page"))?;
    form.submit().await.map_err(fail("submit"))?;
    let deadline = Instant::now() + PAGE_LOAD;
    loop {
        let loaded = client
            .execute(
                "return window.x30Mark === undefined && document.readyState === 'complete';",
                vec![],
            )
            .await;
        if let Ok(serde_json::Value::Bool(true)) = loaded {
            return page_text(client).await.map_err(fail("read the answer"));
        }
        if Instant::now() >= deadline {
            return Err(format!("no answer to the form within {PAGE_LOAD:?}"));
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Waits for a line of x30-qemu's output from index `from` on that is `line`; its index.
fn line_after(panel: &Running, from: usize, line: &str) -> Result<usize, String> {
    panel
        .stdout
        .wait_for(from, REACTION, |l| l == line)
        .map(|(index, _)| index)
        .ok_or_else(|| format!("no `{line}` within {REACTION:?}"))
}

/// The console's answer to `show speed-forward` when it is `speed`, saved.
fn speed_shown(speed: &str) -> String {
    format!("console: {:<18} = {speed}  [set]", "speed-forward")
}

/// Turns a WebDriver error into the test's, saying what was being done.
fn fail(what: &'static str) -> impl Fn(CmdError) -> String {
    move |e| format!("{what}: {e}")
}

#[test]
fn the_page_follows_the_robot_and_saves_settings_only_with_the_pin() {
    let Some(turn) = turn() else { return };
    let (Some(chromium), Some(chromedriver)) = (on_path("chromium"), on_path("chromedriver"))
    else {
        let _ = writeln!(std::io::stderr(), "SKIPPED: chromium missing");
        return;
    };
    let sim = simulator();
    let http = format!("127.0.0.1:{}", free_port());
    let mut panel = boot_with(&turn, &sim, WEB_SESSION, &["--http", &http]);
    let driver = Driver::start(&chromedriver);
    let profile = tempfile::Builder::new()
        .prefix("x30-web-test-")
        .tempdir()
        .expect("browser profile folder");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("tokio runtime");

    let outcome: Result<(), String> = runtime.block_on(async {
        let client = browser(&driver, &chromium, profile.path()).await;
        let checked = tokio::time::timeout(
            WEB_SESSION,
            check_page(&client, &sim, &mut panel, &format!("http://{http}")),
        )
        .await
        .unwrap_or_else(|_| Err(format!("the browser checks took over {WEB_SESSION:?}")));
        // The browser goes whatever the checks found; then chromedriver is killed.
        let _ = tokio::time::timeout(DRIVER_START, client.close()).await;
        checked
    });
    drop(driver);
    if let Err(why) = outcome {
        panic!(
            "{why}\n--- x30-qemu stdout\n{}\n--- stderr\n{}",
            panel.stdout.all().join("\n"),
            panel.stderr.all().join("\n")
        );
    }
    finish(panel);
}

/// Everything the test checks in the browser, on the page at `base`.
async fn check_page(
    client: &Client,
    sim: &Simulator,
    panel: &mut Running,
    base: &str,
) -> Result<(), String> {
    // The status page shows the battery level the robot reports...
    hold_battery(sim, 73.4);
    client
        .goto(&format!("{base}/"))
        .await
        .map_err(fail("open /"))?;
    battery_level_shows(client, sim, 73).await?;
    if let Some(file) = std::env::var_os("X30_WEB_SCREENSHOT") {
        let png = client.screenshot().await.map_err(fail("screenshot"))?;
        std::fs::write(&file, png).map_err(|e| format!("{}: {e}", file.to_string_lossy()))?;
        eprintln!(
            "screenshot of the status page saved to {}",
            file.to_string_lossy()
        );
    }
    // ... and follows a change of it by itself: the mark set in the page survives, so
    // the page was not loaded again.
    client
        .execute("window.x30Mark = 'same page';", vec![])
        .await
        .map_err(fail("mark the page"))?;
    battery_level_shows(client, sim, 41).await?;
    let mark = client
        .execute("return window.x30Mark;", vec![])
        .await
        .map_err(fail("read the mark"))?;
    if mark != json!("same page") {
        return Err(format!("the status page was loaded again (mark {mark})"));
    }
    // A battery answer without its level: the page shows the status's, and says so.
    battery_source_shows(client, "2001").await?;
    sim.update_faults(|f| f.leave_out = vec!["BatteryLevel".into()]);
    battery_source_shows(client, "1002").await?;
    battery_level_shows(client, sim, 58).await?;
    sim.update_faults(|f| f.leave_out.clear());
    battery_source_shows(client, "2001").await?;
    // An answer as old as the panel allows is greyed out: the page's own drawing of the
    // panel's JSON, with the battery answer marked stale, as it is after four missed polls.
    let drawn = client
        .execute_async(
            "const done = arguments[arguments.length - 1];
             fetch('/api/status').then(r => r.json()).then(d => {
                 d.battery.stale = true;
                 show(d);
                 done(document.getElementById('battery').className);
             }, e => done('no status: ' + e));",
            vec![],
        )
        .await
        .map_err(fail("draw a stale battery answer"))?;
    if !drawn
        .as_str()
        .is_some_and(|classes| classes.contains("stale"))
    {
        return Err(format!(
            "a stale battery answer is not marked stale: class {drawn}"
        ));
    }
    // Sections whose JSON has no `stale` of its own (the LEDs; the battery level taken
    // from the status) are drawn the same, not greyed out, however often they are drawn.
    let drawn = client
        .execute_async(
            "const done = arguments[arguments.length - 1];
             fetch('/api/status').then(r => r.json()).then(d => {
                 d.battery = null;
                 const seen = [];
                 for (let i = 0; i < 3; i++) {
                     show(d);
                     seen.push(['leds', 'battery']
                         .map(id => id + ':' + document.getElementById(id).className));
                 }
                 done(seen.join(' '));
             }, e => done('no status: ' + e));",
            vec![],
        )
        .await
        .map_err(fail("draw the LEDs and the status's battery level"))?;
    if drawn
        .as_str()
        .is_none_or(|classes| classes.contains("stale"))
    {
        return Err(format!(
            "current LEDs or battery level drawn as stale: classes {drawn}"
        ));
    }
    // The same from the panel's own JSON: a robot that stops answering its status (each
    // answer held a minute) has it greyed out once the panel holds it too old, two
    // seconds on, and shown again once the robot answers it again.
    stale_shows(client, "#robot", false).await?;
    sim.update_faults(|f| f.type_delays = vec![(1002, Duration::from_secs(60))]);
    stale_shows(client, "#robot", true).await?;
    sim.update_faults(|f| f.type_delays.clear());
    stale_shows(client, "#robot", false).await?;

    // Without a PIN the settings are read-only, and the page says how to set one.
    client
        .goto(&format!("{base}/settings"))
        .await
        .map_err(fail("open /settings"))?;
    let text = page_text(client).await.map_err(fail("read /settings"))?;
    let pin_fields = client
        .find_all(Locator::Css("input[name='pin']"))
        .await
        .map_err(fail("look for a PIN field"))?;
    if !pin_fields.is_empty() || !text.contains("set web-pin") {
        return Err(format!(
            "/settings without a PIN is not read-only with the way to set one:\n{text}"
        ));
    }

    // With a PIN set on the console, the form saves a change with it...
    let from = panel.stdout.len();
    panel.send(&format!("console set web-pin {PIN}"));
    panel.send("console save");
    panel
        .stdout
        .wait_for(from, REACTION, |l| {
            l.starts_with("console: saved web-pin in ")
        })
        .ok_or("the console did not save the PIN")?;
    client.refresh().await.map_err(fail("reload /settings"))?;
    let answer = post_speed(client, "0.7", PIN).await?;
    if !answer.to_lowercase().contains("saved") {
        return Err(format!(
            "no success message after posting with the PIN:\n{answer}"
        ));
    }
    let from = panel.stdout.len();
    panel.send("console show speed-forward");
    let from = line_after(panel, from, &speed_shown("0.7"))? + 1;

    // ... and refuses one with a wrong PIN, changing nothing.
    let answer = post_speed(client, "0.9", "1111").await?;
    if !answer.contains("PIN") {
        return Err(format!(
            "no refusal naming the PIN after a wrong one:\n{answer}"
        ));
    }
    panel.send("console show speed-forward");
    line_after(panel, from, &speed_shown("0.7"))?;
    // The refused form comes back as typed, so that the person only fixes the PIN.
    let typed = client
        .find(Locator::Css("input[name='speed-forward']"))
        .await
        .map_err(fail("find speed-forward"))?
        .prop("value")
        .await
        .map_err(fail("read speed-forward"))?;
    if typed.as_deref() != Some("0.9") {
        return Err(format!(
            "the refused form shows speed-forward {typed:?}, not the 0.9 typed"
        ));
    }
    Ok(())
}

/// Longest one hand-made exchange with the board may take.
const EXCHANGE: Duration = Duration::from_secs(10);

/// Sends `request` to the page at `page` on a new connection and returns what came back
/// before the board closed it (empty if it only closed or reset it).
fn exchange(page: SocketAddr, request: &[u8]) -> String {
    let mut stream = TcpStream::connect_timeout(&page, EXCHANGE).expect("connect");
    stream
        .set_read_timeout(Some(EXCHANGE))
        .expect("read timeout");
    stream
        .set_write_timeout(Some(EXCHANGE))
        .expect("write timeout");
    // The board may answer and close before it has read all of a refused request.
    let _ = stream.write_all(request);
    let mut answer = Vec::new();
    let _ = stream.read_to_end(&mut answer);
    String::from_utf8_lossy(&answer).into_owned()
}

/// The status code of `answer` (`HTTP/1.1 200 …`), if it has a status line.
fn code(answer: &str) -> Option<&str> {
    answer
        .strip_prefix("HTTP/1.1 ")?
        .split_ascii_whitespace()
        .next()
}

/// A `GET` of `path`, closing the connection after the answer.
fn get(path: &str) -> String {
    format!("GET {path} HTTP/1.1\r\nHost: board\r\nConnection: close\r\n\r\n")
}

/// Whether `page` answers `GET /api/status` with 200, trying every 200 ms for `limit`.
fn answers_within(page: SocketAddr, limit: Duration) -> bool {
    let deadline = Instant::now() + limit;
    loop {
        if code(&exchange(page, get("/api/status").as_bytes())) == Some("200") {
            return true;
        }
        if Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn bad_requests_are_refused_and_silent_clients_let_go_while_the_page_carries_on() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let page = SocketAddr::from((Ipv4Addr::LOCALHOST, free_port()));
    let http = page.to_string();
    let panel = boot_with(&turn, &sim, SESSION_LIMIT, &["--http", &http]);

    let status = exchange(page, get("/api/status").as_bytes());
    assert_eq!(code(&status), Some("200"), "{status}");
    let headers = status.to_ascii_lowercase();
    assert!(
        headers.contains("content-type: application/json"),
        "{status}"
    );
    assert!(headers.contains("cache-control: no-store"), "{status}");
    let index = exchange(page, get("/").as_bytes());
    assert_eq!(code(&index), Some("200"), "{index}");
    assert!(
        index
            .to_ascii_lowercase()
            .contains("content-type: text/html; charset=utf-8"),
        "{index}"
    );

    let refused: [(&str, Vec<u8>, &str); 5] = [
        ("an unknown path", get("/nowhere").into_bytes(), "404"),
        (
            "another method",
            b"PUT / HTTP/1.1\r\nContent-Length: 0\r\n\r\n".to_vec(),
            "405",
        ),
        ("a malformed request line", b"HELLO\r\n\r\n".to_vec(), "400"),
        (
            "a header without a colon",
            b"GET / HTTP/1.1\r\nbroken\r\n\r\n".to_vec(),
            "400",
        ),
        (
            "a form over 2048 bytes",
            [
                b"POST /settings HTTP/1.1\r\nContent-Type: application/x-www-form-urlencoded\r\n\
                  Content-Length: 5000\r\n\r\n"
                    .as_slice(),
                &[b'a'; 5000],
            ]
            .concat(),
            "413",
        ),
    ];
    for (what, request, expected) in refused {
        let answer = exchange(page, &request);
        assert_eq!(code(&answer), Some(expected), "{what}: {answer}");
        assert!(answers_within(page, EXCHANGE), "no answer after {what}");
    }
    // Headers longer than the board keeps get no page, and the board carries on.
    let long = format!("GET / HTTP/1.1\r\nX-Long: {}\r\n\r\n", "x".repeat(3000));
    let answer = exchange(page, long.as_bytes());
    assert_ne!(code(&answer), Some("200"), "{answer}");
    assert!(
        answers_within(page, EXCHANGE),
        "no answer after long headers"
    );

    // Clients that connect and say nothing take every server task, for a while only.
    let silent: Vec<TcpStream> = (0..3)
        .map(|_| TcpStream::connect_timeout(&page, EXCHANGE).expect("connect"))
        .collect();
    assert!(
        answers_within(page, EXCHANGE),
        "silent clients kept the page"
    );
    for mut stream in silent {
        stream
            .set_read_timeout(Some(EXCHANGE))
            .expect("read timeout");
        let mut rest = Vec::new();
        // Closed by the board (end of file or a reset), not left to the timeout.
        let closed = match stream.read_to_end(&mut rest) {
            Ok(_) => true,
            Err(e) => {
                e.kind() != std::io::ErrorKind::WouldBlock
                    && e.kind() != std::io::ErrorKind::TimedOut
            }
        };
        assert!(closed, "a silent client still connected after {EXCHANGE:?}");
    }
    finish(panel);
}
