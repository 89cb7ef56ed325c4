//! The viewer keeps few connections and none forever: a flood of idle clients is closed and
//! never crowds out the file descriptors tracking needs, and a WebSocket answers pings and
//! ends on the browser's close.

use crate::common;

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use common::{scene, update};
use flexshape_viewer::{Limits, Update, Viewer};
use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;

/// The viewer's whole answer to `GET /health` on a connection of its own, or `None` when it
/// cannot be asked or does not answer within `wait`.
fn health(addr: SocketAddr, wait: Duration) -> Option<String> {
    let mut s = TcpStream::connect(addr).ok()?;
    s.set_read_timeout(Some(wait)).ok()?;
    let request = format!(
        "GET /health HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nConnection: close\r\n\r\n",
        addr.port()
    );
    s.write_all(request.as_bytes()).ok()?;
    let mut reply = String::new();
    s.read_to_string(&mut reply).ok()?;
    Some(reply)
}

/// Whether the server closes `s` within `within` (reading end of stream or a reset).
fn closed_within(s: &mut TcpStream, within: Duration) -> bool {
    s.set_read_timeout(Some(within)).unwrap();
    let mut buf = [0u8; 256];
    loop {
        match s.read(&mut buf) {
            Ok(0) => return true,
            Ok(_) => continue,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return false;
            }
            Err(_) => return true,
        }
    }
}

#[test]
fn idle_and_surplus_connections_are_closed() {
    let limits = Limits {
        connections: 4,
        idle: Duration::from_millis(400),
        ..Limits::default()
    };
    let viewer = Viewer::start_with("127.0.0.1:0", false, scene(), limits).unwrap();
    let addr = viewer.addr();
    // Four half-sent requests take every place…
    let mut held: Vec<TcpStream> = (0..4)
        .map(|_| {
            let mut s = TcpStream::connect(addr).unwrap();
            s.write_all(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n")
                .unwrap();
            s
        })
        .collect();
    std::thread::sleep(Duration::from_millis(100));
    // …so a fifth is closed at once, without an answer.
    let mut surplus = TcpStream::connect(addr).unwrap();
    assert!(closed_within(&mut surplus, Duration::from_millis(300)));
    // The half-sent ones are closed once idle.
    let start = Instant::now();
    for s in &mut held {
        assert!(closed_within(s, Duration::from_secs(3)));
    }
    let waited = start.elapsed();
    assert!(waited < Duration::from_secs(2), "{waited:?}");
    // And the viewer answers again.
    let reply = health(addr, Duration::from_secs(30)).expect("no answer to /health");
    assert!(reply.starts_with("HTTP/1.1 200"), "{reply}");
}

#[tokio::test]
async fn a_websocket_answers_pings_stays_while_quiet_and_ends_on_close() {
    // A head deadline far shorter than the quiet spell: an upgraded socket sends no heads.
    let limits = Limits {
        connections: 8,
        idle: Duration::from_millis(300),
        head: Duration::from_millis(200),
        ..Limits::default()
    };
    let viewer = Viewer::start_with("127.0.0.1:0", false, scene(), limits).unwrap();
    let url = format!("ws://127.0.0.1:{}/ws", viewer.addr().port());
    let (mut ws, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    let hello = ws.next().await.unwrap().unwrap();
    assert!(hello.to_text().unwrap().contains("\"hello\""));
    ws.send(Message::Ping(b"are you there".to_vec().into()))
        .await
        .unwrap();
    // No frames are published: for three idle times only pings come, and our pong.
    let (mut pong, mut pings) = (false, 0);
    let quiet = tokio::time::sleep(Duration::from_millis(900));
    tokio::pin!(quiet);
    loop {
        tokio::select! {
            _ = &mut quiet => break,
            m = ws.next() => match m {
                Some(Ok(Message::Pong(p))) => pong |= &p[..] == b"are you there",
                Some(Ok(Message::Ping(_))) => pings += 1,
                other => panic!("the viewer closed a quiet but healthy socket: {other:?}"),
            },
        }
    }
    assert!(pong, "our ping answered");
    assert!(pings >= 2, "{pings} pings from the viewer");
    ws.send(Message::Close(None)).await.unwrap();
    let ended = tokio::time::timeout(Duration::from_secs(2), async {
        while let Some(m) = ws.next().await {
            if m.is_err() {
                break;
            }
        }
    })
    .await;
    assert!(ended.is_ok(), "the viewer ended the socket on our close");
}

/// Slow clients cannot hold the page: a request head trickled a byte at a time (which keeps
/// a connection from idling) is closed once its time is up — the first request's, and the
/// next one's on a kept-alive connection — and one address cannot take every place.
#[test]
fn trickled_heads_are_closed_and_one_address_gets_its_share() {
    let limits = Limits {
        connections: 8,
        idle: Duration::from_millis(300),
        per_peer: 3,
        head: Duration::from_millis(700),
    };
    let viewer = Viewer::start_with("127.0.0.1:0", false, scene(), limits).unwrap();
    let addr = viewer.addr();
    let head = format!(
        "GET /health HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
        addr.port()
    );
    // A byte every 100 ms: never idle for 300 ms, but the head is not whole in 700 ms.
    let trickle = |s: &mut TcpStream, bytes: &[u8]| -> Duration {
        let start = Instant::now();
        for b in bytes {
            std::thread::sleep(Duration::from_millis(100));
            if s.write_all(&[*b]).is_err() {
                break;
            }
        }
        s.set_read_timeout(Some(Duration::from_secs(3))).unwrap();
        let mut buf = [0u8; 256];
        while !matches!(s.read(&mut buf), Ok(0) | Err(_)) {}
        start.elapsed()
    };
    let mut slow = TcpStream::connect(addr).unwrap();
    let closed = trickle(&mut slow, head.as_bytes());
    assert!(
        closed < Duration::from_millis(2500),
        "closed after {closed:?}"
    );
    // Kept alive after a whole request, the next head is timed again.
    let mut kept = TcpStream::connect(addr).unwrap();
    kept.write_all(head.as_bytes()).unwrap();
    let mut reply = [0u8; 17];
    kept.read_exact(&mut reply).unwrap();
    assert!(reply.starts_with(b"HTTP/1.1 200"), "{reply:?}");
    let closed = trickle(&mut kept, head.as_bytes());
    assert!(
        closed < Duration::from_millis(2500),
        "kept alive: closed after {closed:?}"
    );
    // Three places for one address: a fourth connection from it is closed at once.
    let mut held: Vec<TcpStream> = (0..3).map(|_| TcpStream::connect(addr).unwrap()).collect();
    std::thread::sleep(Duration::from_millis(50));
    let mut fourth = TcpStream::connect(addr).unwrap();
    assert!(closed_within(&mut fourth, Duration::from_millis(250)));
    // Their places come back with them.
    for s in &mut held {
        assert!(closed_within(s, Duration::from_secs(2)));
    }
    let reply = health(addr, Duration::from_secs(30)).expect("no answer to /health");
    assert!(reply.starts_with("HTTP/1.1 200"), "{reply}");
}

/// A frame of camera noise (it compresses badly: every frame is several hundred kilobytes).
fn noisy_update(frame: u64) -> Update {
    let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ frame;
    let image = image::RgbImage::from_fn(1024, 768, |_, _| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        image::Rgb([state as u8, (state >> 8) as u8, (state >> 16) as u8])
    });
    update(frame, image)
}

#[test]
fn a_browser_that_stops_reading_is_let_go() {
    let limits = Limits {
        connections: 1,
        idle: Duration::from_millis(400),
        ..Limits::default()
    };
    let viewer = Viewer::start_with("127.0.0.1:0", false, scene(), limits).unwrap();
    let addr = viewer.addr();
    // A WebSocket that is opened, then never read: the viewer's sends fill the socket.
    let mut stalled = TcpStream::connect(addr).unwrap();
    let handshake = format!(
        "GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n",
        addr.port()
    );
    stalled.write_all(handshake.as_bytes()).unwrap();
    let healthy =
        || health(addr, Duration::from_secs(2)).is_some_and(|r| r.starts_with("HTTP/1.1 200"));
    // While it holds the only place, others are turned away…
    std::thread::sleep(Duration::from_millis(100));
    assert!(!healthy(), "the stalled socket holds the only place");
    // …until its sends stall for the idle time: then it is closed and the place is free.
    let start = Instant::now();
    let mut frame = 0;
    let freed = loop {
        viewer.publish(noisy_update(frame));
        frame += 1;
        std::thread::sleep(Duration::from_millis(50));
        if start.elapsed() > Duration::from_secs(1) && healthy() {
            break true;
        }
        if start.elapsed() > Duration::from_secs(30) {
            break false;
        }
    };
    assert!(
        freed,
        "the stalled browser still holds its place after 30 s"
    );
    println!(
        "let go after {:.1} s and {frame} frames",
        start.elapsed().as_secs_f64()
    );
}
