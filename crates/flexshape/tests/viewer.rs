//! The live viewer in a real browser: headless Chromium (Debian's `chromium` and
//! `chromium-driver`) driven over WebDriver opens the viewer of a running demo, sees frames
//! arrive and the figures change, and takes a screenshot that is not blank; then Ctrl-C ends
//! the demo cleanly with its summary. Skipped with a message when Chromium is not installed,
//! unless `FLEXSHAPE_REQUIRE_BROWSER=1` (CI sets it, and installs both packages).

mod common;

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use fantoccini::{Client, ClientBuilder};
use serde_json::{Value, json};

const CHROMIUM: &str = "/usr/bin/chromium";
const CHROMEDRIVER: &str = "/usr/bin/chromedriver";

fn browser_or_skip() -> bool {
    let present = [CHROMIUM, CHROMEDRIVER]
        .iter()
        .all(|p| std::path::Path::new(p).is_file());
    if present {
        return true;
    }
    assert!(
        std::env::var("FLEXSHAPE_REQUIRE_BROWSER").as_deref() != Ok("1"),
        "FLEXSHAPE_REQUIRE_BROWSER=1 but {CHROMIUM} or {CHROMEDRIVER} is missing"
    );
    eprintln!("skipped: install Debian's chromium and chromium-driver to run the browser test");
    false
}

/// A child process killed when the test ends, however it ends.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Evaluates `script` (a function body) in the page.
async fn eval(c: &Client, script: &str) -> Value {
    c.execute(script, vec![]).await.unwrap()
}

/// Waits until `script` returns true, up to `timeout`.
async fn wait_for(c: &Client, script: &str, timeout: Duration, what: &str) {
    let start = Instant::now();
    while eval(c, script).await != json!(true) {
        assert!(start.elapsed() < timeout, "waited {timeout:?} for {what}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

async fn text_of(c: &Client, id: &str) -> String {
    eval(
        c,
        &format!("return document.getElementById('{id}').textContent;"),
    )
    .await
    .as_str()
    .unwrap_or_default()
    .to_string()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_viewer_shows_a_live_demo_in_chromium() {
    if !browser_or_skip() {
        return;
    }
    // The demo, live, with the viewer on a free port (it prints the address).
    let mut demo = Running(
        Command::new(env!("CARGO_BIN_EXE_flexshape"))
            .args(["demo", "--viewer", "127.0.0.1:0", "--fps", "6"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let (tx, rx) = mpsc::channel();
    let stderr = demo.0.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let url = loop {
        let line = rx
            .recv_timeout(Duration::from_secs(60))
            .expect("the demo prints the viewer's address");
        if let Some(url) = line.strip_prefix("viewer: ") {
            break url.trim().to_string();
        }
    };
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");

    let port = free_port();
    let _driver = Running(
        Command::new(CHROMEDRIVER)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let profile = tempfile::tempdir().unwrap();
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": CHROMIUM,
            "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--disable-quic", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--window-size=1440,1000",
                format!("--user-data-dir={}", profile.path().display()),
            ]
        }),
    );
    let start = Instant::now();
    let c = loop {
        let connector = hyper_util::client::legacy::connect::HttpConnector::new();
        match ClientBuilder::new(connector)
            .capabilities(caps.clone())
            .connect(&format!("http://127.0.0.1:{port}"))
            .await
        {
            Ok(c) => break c,
            Err(e) => {
                assert!(
                    start.elapsed() < Duration::from_secs(30),
                    "chromedriver: {e}"
                );
                tokio::time::sleep(Duration::from_millis(300)).await;
            }
        }
    };

    c.goto(&url).await.unwrap();
    let long = Duration::from_secs(60);
    wait_for(
        &c,
        "return Number(document.body.dataset.frames) >= 3;",
        long,
        "3 frames",
    )
    .await;
    wait_for(
        &c,
        "const i = document.getElementById('frame-0'), s = document.getElementById('sil-2');
         return !!i && !!s && i.naturalWidth === 320 && s.naturalWidth === 320;",
        long,
        "camera frames and silhouettes",
    )
    .await;
    assert_eq!(text_of(&c, "conn").await, "live");
    assert_eq!(text_of(&c, "status").await, "ok");
    let (frame, tip) = (text_of(&c, "frame").await, text_of(&c, "tip").await);
    let seen = eval(&c, "return Number(document.body.dataset.frames);").await;
    wait_for(
        &c,
        &format!(
            "return Number(document.body.dataset.frames) >= {} + 3;",
            seen
        ),
        long,
        "three more frames",
    )
    .await;
    let (frame2, tip2) = (text_of(&c, "frame").await, text_of(&c, "tip").await);
    assert_ne!(frame, frame2, "the frame number moves on");
    assert_ne!(tip, tip2, "the tip moves with the sweep");
    assert!(
        tip2.ends_with(" mm") && tip2.split(',').count() == 3,
        "{tip2}"
    );
    let truth = text_of(&c, "truth").await;
    assert!(
        truth.starts_with("rms 0."),
        "sub-millimetre against truth: {truth}"
    );

    // Drag the 3-D view: it redraws rotated.
    let before = eval(&c, "return document.getElementById('view3d').toDataURL();").await;
    eval(
        &c,
        "const v = document.getElementById('view3d'), o = {bubbles: true, pointerId: 1};
         v.dispatchEvent(new PointerEvent('pointerdown', {...o, clientX: 100, clientY: 100}));
         v.dispatchEvent(new PointerEvent('pointermove', {...o, clientX: 180, clientY: 130}));
         v.dispatchEvent(new PointerEvent('pointerup', o)); return true;",
    )
    .await;
    let after = eval(&c, "return document.getElementById('view3d').toDataURL();").await;
    assert_ne!(before, after, "the 3-D view turns");

    let png = c.screenshot().await.unwrap();
    let shot = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("viewer.png");
    std::fs::write(&shot, &png).unwrap();
    let (ink, colours) = common::ink(&shot);
    assert!(
        ink > 0.5 && colours > 200,
        "screenshot {}: ink {ink:.2}, {colours} colours",
        shot.display()
    );
    c.close().await.unwrap();

    // Ctrl-C: the demo finishes its frames in flight and prints its summary.
    let pid = demo.0.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-INT", &pid])
            .status()
            .unwrap()
            .success()
    );
    let start = Instant::now();
    let status = loop {
        if let Some(s) = demo.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "the demo ends after Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut out = String::new();
    std::io::Read::read_to_string(&mut demo.0.stdout.take().unwrap(), &mut out).unwrap();
    assert!(status.success(), "{status}: {out}");
    assert!(
        out.contains("against truth") && out.contains("dropped"),
        "{out}"
    );
}

#[test]
fn the_viewer_stays_on_loopback_unless_told() {
    let e = common::fails(&["demo", "--viewer", "0.0.0.0:0", "--frames", "1"]);
    assert!(e.contains("--allow-remote"), "{e}");
    let e = common::fails(&["demo", "--viewer", "localhost", "--frames", "1"]);
    assert!(e.contains("HOST:PORT"), "{e}");
}
