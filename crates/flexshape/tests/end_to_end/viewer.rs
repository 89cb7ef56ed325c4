//! The live viewer in a real browser: headless Chromium (Debian's `chromium` and
//! `chromium-driver`) driven over WebDriver opens the viewer of a running demo, sees frames
//! arrive and the figures change, and takes a screenshot that is not blank; then Ctrl-C ends
//! the demo cleanly with its summary. Skipped with a message when Chromium is not installed,
//! unless `FLEXSHAPE_REQUIRE_BROWSER=1` (CI sets it, and installs both packages).

use crate::common;

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

/// Runs `flexshape ARGS` (which start the viewer on a free port) and the viewer's address
/// once it prints it.
fn spawn_with_viewer(args: &[&str]) -> (Running, String) {
    let mut child = Running(
        Command::new(env!("CARGO_BIN_EXE_flexshape"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let (tx, rx) = mpsc::channel();
    let stderr = child.0.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let url = loop {
        let line = rx
            .recv_timeout(Duration::from_secs(60))
            .expect("the command prints the viewer's address");
        if let Some(url) = line.strip_prefix("viewer: ") {
            break url.trim().to_string();
        }
    };
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");
    (child, url)
}

/// Headless Chromium under chromedriver, with its driver process and profile folder.
async fn browser() -> (Client, Running, tempfile::TempDir) {
    let port = free_port();
    let driver = Running(
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
    let client = loop {
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
    (client, driver, profile)
}

/// Saves a screenshot of the page as `name` in the test's folder, and checks it is not blank.
async fn screenshot(c: &Client, name: &str) {
    let png = c.screenshot().await.unwrap();
    let shot = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::write(&shot, &png).unwrap();
    let (ink, colours) = common::ink(&shot);
    assert!(
        ink > 0.5 && colours > 200,
        "screenshot {}: ink {ink:.2}, {colours} colours",
        shot.display()
    );
}

/// Ctrl-C to the command: it ends cleanly within 30 s; its standard output.
fn interrupt(child: &mut Running) -> String {
    let pid = child.0.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-INT", &pid])
            .status()
            .unwrap()
            .success()
    );
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "the command ends after Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut out = String::new();
    std::io::Read::read_to_string(&mut child.0.stdout.take().unwrap(), &mut out).unwrap();
    assert!(status.success(), "{status}: {out}");
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_viewer_shows_a_live_demo_in_chromium() {
    if !browser_or_skip() {
        return;
    }
    // The demo, live, with the viewer on a free port (it prints the address).
    let (mut demo, url) = spawn_with_viewer(&["demo", "--viewer", "127.0.0.1:0", "--fps", "6"]);
    let (c, _driver, _profile) = browser().await;
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
    overlays_lie_on_the_silhouettes(&c).await;
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
    views_fit_the_tube_and_zoom(&c).await;
    // The cameras' frusta in 3-D, on request: each camera's colour appears in the view.
    let colours = |on: bool| {
        format!(
            "const t = document.getElementById('show-cameras'); t.checked = {on};
             t.dispatchEvent(new Event('change'));
             const v = document.getElementById('view3d');
             const d = v.getContext('2d').getImageData(0, 0, v.width, v.height).data;
             const count = (r, g, b) => {{ let n = 0; for (let i = 0; i < d.length; i += 4)
               if (d[i + 3] > 200 && Math.abs(d[i] - r) < 8 && Math.abs(d[i + 1] - g) < 8
                   && Math.abs(d[i + 2] - b) < 8) n++;
               return n; }};
             return [Number(v.dataset.frusta), count(230, 216, 90), count(90, 216, 230),
                     count(216, 140, 255)];"
        )
    };
    let (without, with) = (
        eval(&c, &colours(false)).await,
        eval(&c, &colours(true)).await,
    );
    println!("frusta shown, and pixels of each camera's colour: {without} without, {with} with");
    assert_eq!((without[0].clone(), with[0].clone()), (json!(0), json!(3)));
    assert!(
        (1..4).all(|i| with[i].as_f64().unwrap() > without[i].as_f64().unwrap() + 40.0),
        "{without} {with}"
    );
    // The time series: a line in every panel (below its title) and the stage bar.
    let inked = eval(
        &c,
        "const c = document.getElementById('series'), w = c.width;
         const d = c.getContext('2d').getImageData(0, 0, w, c.height).data;
         const ink = (top, bottom) => { let n = 0;
           for (let y = top; y < bottom; y++) for (let x = 60; x < w - 12; x++) {
             const i = 4 * (y * w + x);
             if (d[i + 3] > 0 && !(d[i] === 58 && d[i + 1] === 64 && d[i + 2] === 80)) n++; }
           return n; };
         return [ink(18, 72), ink(94, 128), ink(150, 184), ink(206, 240), ink(262, 306),
                 ink(330, 346), Number(c.dataset.points)];",
    )
    .await;
    println!("time series ink per panel, and frames remembered: {inked}");
    let inked: Vec<f64> = inked
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(inked[6] >= 6.0, "frames remembered: {}", inked[6]);
    assert!(
        // A drawn line inks 97–650 px of a panel over its first dozen frames (the least on
        // a loaded machine, whose fewer frames span less of it); an undrawn one none.
        inked[..5].iter().all(|&n| n > 50.0) && inked[5] > 5000.0,
        "{inked:?}"
    );

    eval(
        &c,
        "document.getElementById('series').scrollIntoView(); return true;",
    )
    .await;
    screenshot(&c, "viewer.png").await;
    c.close().await.unwrap();

    // Ctrl-C: the demo finishes its frames in flight and prints its summary.
    let out = interrupt(&mut demo);
    assert!(
        out.contains("against truth") && out.contains("dropped"),
        "{out}"
    );
}

/// The views frame the tube (closer than the whole volume in the top view: 1.8× on this demo), the
/// wheel zooms one view (its grid follows), and a double click returns to the fitted view.
async fn views_fit_the_tube_and_zoom(c: &Client) {
    let scale = |id: &str| format!("return Number(document.getElementById('{id}').dataset.scale);");
    let grid = |id: &str| format!("return Number(document.getElementById('{id}').dataset.gridMm);");
    let fitted = eval(c, &scale("top")).await.as_f64().unwrap();
    let toggle = |on: bool| {
        format!(
            "const t = document.getElementById('fit-tube'); t.checked = {on};
             t.dispatchEvent(new Event('change')); return true;"
        )
    };
    eval(c, &toggle(false)).await;
    let whole = eval(c, &scale("top")).await.as_f64().unwrap();
    eval(c, &toggle(true)).await;
    println!("top view: {fitted} px/mm fitted to the tube, {whole} px/mm for the volume");
    assert!(
        fitted > 1.5 * whole,
        "the fitted view is closer: {fitted} against {whole} px/mm"
    );
    let before = eval(c, &grid("top")).await.as_f64().unwrap();
    eval(
        c,
        "const v = document.getElementById('top'), r = v.getBoundingClientRect();
         for (let i = 0; i < 3; i++) v.dispatchEvent(new WheelEvent('wheel', {deltaY: -400,
           clientX: r.left + r.width / 2, clientY: r.top + r.height / 2, bubbles: true, cancelable: true}));
         return true;",
    )
    .await;
    let zoomed = eval(c, &grid("top")).await.as_f64().unwrap();
    assert!(zoomed < before, "zoomed in: grid {zoomed} mm, was {before}");
    eval(
        c,
        "document.getElementById('top').dispatchEvent(new MouseEvent('dblclick', {bubbles: true}));
         return true;",
    )
    .await;
    assert_eq!(
        eval(c, "return [zoomPan.top.zoom, ...zoomPan.top.pan];").await,
        json!([1, 0, 0]),
        "back to the fitted view"
    );
}

/// Over every camera's frame the page draws the fitted tube's outline, centerline, bands and
/// tip: the ink lies on that camera's silhouette (97 % of it within 3 px of the page's 256-px
/// image), the camera's residual and overlap are shown, and the overlay and the silhouette
/// blend follow their toggles.
async fn overlays_lie_on_the_silhouettes(c: &Client) {
    let ink = "const out = [];
        for (let i = 0; i < 3; i++) {
          const o = document.getElementById('overlay-' + i), s = document.getElementById('sil-' + i);
          const w = o.width, h = o.height, t = document.createElement('canvas');
          t.width = w; t.height = h;
          const tc = t.getContext('2d'); tc.drawImage(s, 0, 0, w, h);
          const sil = tc.getImageData(0, 0, w, h).data, ov = o.getContext('2d').getImageData(0, 0, w, h).data;
          let ink = 0, near = 0;
          for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) {
            if (ov[4 * (y * w + x) + 3] < 128) continue;
            ink++;
            let hit = false;
            for (let dy = -3; dy <= 3 && !hit; dy++) for (let dx = -3; dx <= 3 && !hit; dx++) {
              const X = x + dx, Y = y + dy;
              if (X >= 0 && Y >= 0 && X < w && Y < h && sil[4 * (Y * w + X)] > 150) hit = true;
            }
            if (hit) near++;
          }
          out.push([ink, near]);
        }
        return out;";
    // The images load a moment after the overlay is drawn: asked again until they agree.
    let deadline = Instant::now() + Duration::from_secs(30);
    let on_silhouettes = |counts: &Value| {
        counts.as_array().unwrap().iter().all(|pair| {
            let (ink, near) = (pair[0].as_f64().unwrap(), pair[1].as_f64().unwrap());
            ink > 150.0 && near > 0.97 * ink
        })
    };
    let mut counts = eval(c, ink).await;
    while !on_silhouettes(&counts) && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(100)).await;
        counts = eval(c, ink).await;
    }
    println!("overlay pixels (all, on the silhouette) per camera: {counts}");
    assert!(on_silhouettes(&counts), "{counts}");
    screenshot(c, "viewer-overlays.png").await;
    // The simulated truth comes with the frame and over each camera's image.
    let truth = eval(
        c,
        "return [last.truth_centerline.length, ...shape.overlays.map((o) => o.truth.filter((p) => p).length)];",
    )
    .await;
    println!("truth points in the frame and over each camera: {truth}");
    assert!(
        truth
            .as_array()
            .unwrap()
            .iter()
            .all(|n| n.as_f64().unwrap() > 50.0),
        "{truth}"
    );
    let check = text_of(c, "check-1").await;
    assert!(
        check.starts_with("residual 0.") && check.contains("IoU 0.9"),
        "{check}"
    );
    // Toggled off, the overlays are cleared at the next frame; the blend shows on request.
    eval(
        c,
        "const t = document.getElementById('show-overlay'); t.checked = false;
         t.dispatchEvent(new Event('change')); return true;",
    )
    .await;
    let blank = "const o = document.getElementById('overlay-0');
        const d = o.getContext('2d').getImageData(0, 0, o.width, o.height).data;
        for (let i = 3; i < d.length; i += 4) if (d[i]) return false;
        return true;";
    assert_eq!(eval(c, blank).await, Value::Bool(true), "overlay off");
    assert_eq!(
        eval(c, "return document.getElementById('blend-0').hidden;").await,
        Value::Bool(true)
    );
    eval(
        c,
        "for (const id of ['show-overlay', 'show-blend']) { const t = document.getElementById(id);
           t.checked = true; t.dispatchEvent(new Event('change')); } return true;",
    )
    .await;
    assert_eq!(
        eval(c, "return document.getElementById('blend-0').hidden;").await,
        Value::Bool(false)
    );
}

/// `model steer --viewer`: the closed loop live — the steering figures, the target drawn in
/// the views, the tip's error and the curvatures over the frames — and the last frame kept
/// until Ctrl-C.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_viewer_shows_the_closed_loop_in_chromium() {
    if !browser_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    std::fs::write(&params, common::run(&["model", "template"])).unwrap();
    let (mut steer, url) = spawn_with_viewer(&[
        "model",
        "steer",
        "--params",
        params.to_str().unwrap(),
        "--targets",
        "2",
        "--steps",
        "6",
        "--viewer",
        "127.0.0.1:0",
    ]);
    let (c, _driver, _profile) = browser().await;
    c.goto(&url).await.unwrap();
    let long = Duration::from_secs(60);
    wait_for(
        &c,
        "return !document.getElementById('steer-fig').hidden &&
                !document.getElementById('steer-panel').hidden;",
        long,
        "the steering figures",
    )
    .await;
    let steer_text = text_of(&c, "steer").await;
    assert!(
        steer_text.starts_with("target ")
            && steer_text.contains("mm from it")
            && steer_text.contains("Kx, Kz"),
        "{steer_text}"
    );
    // Ink in both panels of the history, and the target's magenta in the 3-D view.
    let count = |canvas: &str, test: &str| {
        format!(
            "const c = document.getElementById('{canvas}'), d = c.getContext('2d')
               .getImageData(0, 0, c.width, c.height).data;
             let n = 0; for (let i = 0; i < d.length; i += 4) {{
               const r = d[i], g = d[i + 1], b = d[i + 2], a = d[i + 3]; if ({test}) n++; }}
             return n;"
        )
    };
    let blue = eval(&c, &count("steerplot", "a > 0 && b > 200 && r < 120")).await;
    let orange = eval(
        &c,
        &count("steerplot", "a > 0 && r > 200 && g > 150 && b < 120"),
    )
    .await;
    let target = eval(
        &c,
        &count("view3d", "a > 0 && r > 200 && g < 120 && b > 180"),
    )
    .await;
    println!("steering plot: {blue} blue, {orange} orange px; target {target} magenta px");
    assert!(blue.as_u64().unwrap() > 50 && orange.as_u64().unwrap() > 50);
    assert!(target.as_u64().unwrap() > 20);
    eval(
        &c,
        "document.getElementById('steer-panel').scrollIntoView(); return true;",
    )
    .await;
    screenshot(&c, "viewer-steer.png").await;
    c.close().await.unwrap();
    let out = interrupt(&mut steer);
    assert!(
        out.contains("frames; tip at the end of each target"),
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

/// `track --viewer`: after the last frame the page stays up with it until Ctrl-C (the records
/// and the summary already written), which then ends the run successfully; `--viewer-exit`
/// ends with the input.
#[test]
fn track_keeps_the_viewer_until_ctrl_c_unless_told() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    common::run(&["simulate", "--out", rec.to_str().unwrap(), "--frames", "3"]);
    let out = dir.path().join("shapes.jsonl");
    let (mut track, url) = spawn_with_viewer(&[
        "track",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--viewer",
        "127.0.0.1:0",
    ]);
    let start = Instant::now();
    let finished = || {
        std::fs::read_to_string(&out).is_ok_and(|t| t.lines().any(|l| l.contains("\"summary\"")))
    };
    while !finished() {
        assert!(start.elapsed() < Duration::from_secs(60), "tracking ends");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(800));
    assert!(
        track.0.try_wait().unwrap().is_none(),
        "still serving after the last frame"
    );
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    let mut page = std::net::TcpStream::connect(addr).expect("the viewer still answers");
    std::io::Write::write_all(
        &mut page,
        format!("GET / HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n").as_bytes(),
    )
    .unwrap();
    let mut reply = String::new();
    std::io::Read::read_to_string(&mut page, &mut reply).unwrap();
    assert!(reply.starts_with("HTTP/1.1 200"), "{reply:.80}");
    interrupt(&mut track);
    let lines = std::fs::read_to_string(&out).unwrap();
    assert_eq!(lines.lines().count(), 4, "3 records and the summary");

    let o = Command::new(env!("CARGO_BIN_EXE_flexshape"))
        .args(["track", rec.to_str().unwrap(), "--out", "-"])
        .args(["--viewer", "127.0.0.1:0", "--viewer-exit"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = common::fails(&["track", rec.to_str().unwrap(), "--viewer-exit"]);
    assert!(e.contains("--viewer"), "{e}");
}

/// `view FILE.jsonl`: the records play back at their pace; the page pauses, steps and seeks; a
/// recording plays the same, with its images, each frame tracked as it is shown.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_record_stream_replays_with_pause_step_and_seek() {
    if !browser_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let rec = rec.to_str().unwrap();
    common::run(&["simulate", "--out", rec, "--frames", "8", "--motion", "4"]);
    let shapes = dir.path().join("shapes.jsonl");
    let shapes = shapes.to_str().unwrap();
    common::run(&["track", rec, "--out", shapes]);
    let (mut view, url) = spawn_with_viewer(&["view", shapes, "--viewer", "127.0.0.1:0"]);
    let (c, _driver, _profile) = browser().await;
    c.goto(&url).await.unwrap();
    let long = Duration::from_secs(60);
    // The page may connect after the 2-s stream has ended (it then pauses on the last record):
    // seeking, stepping and playing work from wherever it is.
    wait_for(
        &c,
        "return !document.getElementById('replay').hidden && Number(document.body.dataset.frames) >= 1;",
        long,
        "the replay",
    )
    .await;
    let click = |id: &str| format!("document.getElementById('{id}').click(); return true;");
    eval(
        &c,
        "const s = document.getElementById('replay-seek'); s.value = '2';
         s.dispatchEvent(new Event('input')); return true;",
    )
    .await;
    wait_for(
        &c,
        "return document.getElementById('frame').textContent === '2' &&
                document.getElementById('replay-at').textContent === '3 / 8' &&
                document.getElementById('replay-play').textContent === 'play';",
        long,
        "record 2, paused, after seeking",
    )
    .await;
    eval(&c, &click("replay-next")).await;
    wait_for(
        &c,
        "return document.getElementById('frame').textContent === '3';",
        long,
        "one record on",
    )
    .await;
    eval(&c, &click("replay-back")).await;
    wait_for(
        &c,
        "return document.getElementById('frame').textContent === '2';",
        long,
        "one record back",
    )
    .await;
    // Still paused: nothing moves on by itself.
    tokio::time::sleep(Duration::from_millis(600)).await;
    assert_eq!(text_of(&c, "frame").await, "2");
    eval(&c, &click("replay-play")).await;
    wait_for(
        &c,
        "return Number(document.getElementById('frame').textContent) > 2;",
        long,
        "playing on",
    )
    .await;
    c.close().await.unwrap();
    interrupt(&mut view);
    // A recording plays the same, each frame tracked as it is shown: with its images and the
    // shape over them; a seek lands on the frame asked for.
    let (mut view, url) = spawn_with_viewer(&["view", rec, "--viewer", "127.0.0.1:0"]);
    let (c, _driver, _profile) = browser().await;
    c.goto(&url).await.unwrap();
    wait_for(
        &c,
        "return !document.getElementById('replay').hidden &&
                document.getElementById('replay-at').textContent.endsWith(' / 8');",
        long,
        "the recording's 8 frames",
    )
    .await;
    eval(
        &c,
        "const s = document.getElementById('replay-seek'); s.value = '5';
         s.dispatchEvent(new Event('input')); return true;",
    )
    .await;
    wait_for(
        &c,
        "const i = document.getElementById('frame-0');
         return document.getElementById('frame').textContent === '5' && !!i &&
                i.naturalWidth === 320 && typeof shape === 'object' && shape !== null &&
                shape.frame === 5 && shape.overlays[0].sides[0].length > 50;",
        long,
        "frame 5 with its images and the shape over them",
    )
    .await;
    c.close().await.unwrap();
    interrupt(&mut view);
    let empty = dir.path().join("empty.jsonl");
    std::fs::write(&empty, "").unwrap();
    let e = common::fails(&["view", empty.to_str().unwrap()]);
    assert!(e.contains("holds no records"), "{e}");
}
