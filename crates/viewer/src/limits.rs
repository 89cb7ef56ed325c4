//! The connections the viewer keeps: at most [`Limits::connections`] at once, and at most
//! [`Limits::per_peer`] from one address — beyond, a new one is closed as soon as it is
//! accepted, so that browsers, scanners or a flood can never take the file descriptors
//! tracking needs — each closed once [`Limits::idle`] passes without a byte either way (a
//! client that stopped reading), and each whose request head (its line and headers) has not
//! arrived whole [`Limits::head`] after the connection opened or its last answer was sent
//! (a client trickling a byte now and then keeps a connection from idling, not from this). A
//! WebSocket is pinged more often than the idle time, so a healthy browser never idles out;
//! once upgraded it sends no more request heads.

use std::collections::HashMap;
use std::io;
use std::net::{IpAddr, SocketAddr};
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use axum::serve::Listener;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio::time::{Instant, Sleep};

/// How many connections the viewer keeps and for how long an idle one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Connections open at once, at most.
    pub connections: usize,
    /// A connection without a byte read or written for this long is closed (at least 0.1 s).
    pub idle: Duration,
    /// Connections open at once from one address, at most.
    pub per_peer: usize,
    /// A request's head must arrive whole within this long of the connection's opening or of
    /// the answer before it, else the connection is closed (at least 0.1 s).
    pub head: Duration,
}

impl Default for Limits {
    /// 64 connections (a few browser tabs use 2–6 each), 16 from one address, 30 s idle, 10 s
    /// for a request head (a browser sends one in a single packet).
    fn default() -> Self {
        Limits {
            connections: 64,
            idle: Duration::from_secs(30),
            per_peer: 16,
            head: Duration::from_secs(10),
        }
    }
}

impl Limits {
    /// The idle time, at least [`MIN_IDLE`].
    pub(crate) fn idle(&self) -> Duration {
        self.idle.max(MIN_IDLE)
    }

    /// The time for a request head, at least [`MIN_IDLE`].
    fn head(&self) -> Duration {
        self.head.max(MIN_IDLE)
    }
}

/// The shortest idle time kept to.
const MIN_IDLE: Duration = Duration::from_millis(100);

/// A listener that holds to [`Limits`].
pub(crate) struct Limited {
    listener: TcpListener,
    permits: Arc<Semaphore>,
    peers: Arc<Mutex<HashMap<IpAddr, usize>>>,
    per_peer: usize,
    idle: Duration,
    head: Duration,
}

impl Limited {
    pub(crate) fn new(listener: TcpListener, limits: Limits) -> Self {
        Limited {
            listener,
            permits: Arc::new(Semaphore::new(limits.connections.max(1))),
            peers: Arc::default(),
            per_peer: limits.per_peer.max(1),
            idle: limits.idle(),
            head: limits.head(),
        }
    }

    /// A place for a connection from `ip`, or `None` when it already has its share.
    fn place_for(&self, ip: IpAddr) -> Option<PeerPlace> {
        let mut peers = self.peers.lock().unwrap_or_else(|e| e.into_inner());
        let open = peers.entry(ip).or_insert(0);
        if *open >= self.per_peer {
            return None;
        }
        *open += 1;
        Some(PeerPlace {
            peers: self.peers.clone(),
            ip,
        })
    }
}

impl Listener for Limited {
    type Io = Guarded;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Guarded, SocketAddr) {
        loop {
            let (stream, addr) = Listener::accept(&mut self.listener).await;
            let Some(place) = self.place_for(addr.ip()) else {
                // Closed at once: the descriptor is back before the next accept.
                drop(stream);
                continue;
            };
            match self.permits.clone().try_acquire_owned() {
                Ok(permit) => {
                    let guarded = Guarded::new(stream, (permit, place), self.idle, self.head);
                    return (guarded, addr);
                }
                Err(_) => drop(stream),
            }
        }
    }

    fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }
}

/// One connection's count against its address's share, given back when dropped.
pub(crate) struct PeerPlace {
    peers: Arc<Mutex<HashMap<IpAddr, usize>>>,
    ip: IpAddr,
}

impl Drop for PeerPlace {
    fn drop(&mut self) {
        let mut peers = self.peers.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(open) = peers.get_mut(&self.ip) {
            *open = open.saturating_sub(1);
            if *open == 0 {
                peers.remove(&self.ip);
            }
        }
    }
}

/// The end of a request head.
const HEAD_END: u32 = u32::from_be_bytes(*b"\r\n\r\n");

/// An accepted connection: it holds its places under the limits until dropped, and fails
/// with `TimedOut` once idle too long or once a request head is late.
pub(crate) struct Guarded {
    stream: TcpStream,
    _places: (OwnedSemaphorePermit, PeerPlace),
    idle: Duration,
    deadline: Pin<Box<Sleep>>,
    head: Duration,
    /// When the awaited request head must have arrived (`None`: none awaited).
    head_deadline: Option<Pin<Box<Sleep>>>,
    /// The last four bytes read, to find a head's end across reads.
    tail: u32,
    /// Switched to a WebSocket: no more request heads come.
    upgraded: bool,
}

impl Guarded {
    fn new(
        stream: TcpStream,
        places: (OwnedSemaphorePermit, PeerPlace),
        idle: Duration,
        head: Duration,
    ) -> Self {
        Guarded {
            stream,
            _places: places,
            idle,
            deadline: Box::pin(tokio::time::sleep(idle)),
            head,
            head_deadline: Some(Box::pin(tokio::time::sleep(head))),
            tail: 0,
            upgraded: false,
        }
    }

    /// Bytes moved: the connection is alive.
    fn touch(&mut self) {
        let next = Instant::now() + self.idle;
        self.deadline.as_mut().reset(next);
    }

    /// Bytes read: a request head that ends among them has arrived.
    fn read(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.tail = (self.tail << 8) | u32::from(b);
            if self.tail == HEAD_END {
                self.head_deadline = None;
            }
        }
    }

    /// Bytes written: an answer's head (the server writes it first, and alone or ahead of its
    /// body) starts the wait for the next request's — unless it switches protocols.
    fn wrote(&mut self, bytes: &[u8]) {
        if self.upgraded || !bytes.starts_with(b"HTTP/1.") {
            return;
        }
        if bytes.get(9..12) == Some(b"101") {
            self.upgraded = true;
            self.head_deadline = None;
        } else {
            self.head_deadline = Some(Box::pin(tokio::time::sleep(self.head)));
        }
    }

    /// While waiting on the socket: an error once a deadline has passed (the timers wake the
    /// task when they do).
    fn expired(&mut self, cx: &mut Context<'_>) -> Poll<io::Error> {
        if let Some(head) = self.head_deadline.as_mut()
            && head.as_mut().poll(cx).is_ready()
        {
            return Poll::Ready(io::Error::new(
                io::ErrorKind::TimedOut,
                "viewer request head not received in time",
            ));
        }
        self.deadline
            .as_mut()
            .poll(cx)
            .map(|()| io::Error::new(io::ErrorKind::TimedOut, "viewer connection idle too long"))
    }
}

impl AsyncRead for Guarded {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        let before = buf.filled().len();
        match Pin::new(&mut this.stream).poll_read(cx, buf) {
            Poll::Ready(result) => {
                if buf.filled().len() > before {
                    this.touch();
                    this.read(&buf.filled()[before..]);
                }
                Poll::Ready(result)
            }
            Poll::Pending => this.expired(cx).map(Err),
        }
    }
}

impl AsyncWrite for Guarded {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        data: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        match Pin::new(&mut this.stream).poll_write(cx, data) {
            Poll::Ready(result) => {
                if matches!(result, Ok(n) if n > 0) {
                    this.touch();
                    this.wrote(data);
                }
                Poll::Ready(result)
            }
            Poll::Pending => this.expired(cx).map(Err),
        }
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        match Pin::new(&mut this.stream).poll_flush(cx) {
            Poll::Pending => this.expired(cx).map(Err),
            ready => ready,
        }
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().stream).poll_shutdown(cx)
    }
}
