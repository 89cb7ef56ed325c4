//! The HTTP side: the page, its script, and a WebSocket per browser that always sends the
//! newest encoded frame.

use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::State;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::http::header;
use axum::response::{Html, IntoResponse};
use axum::routing::get;
use tokio::sync::watch;

use crate::encode::{Update, frame_json, image_messages, overlays_json};
use crate::limits::{Limited, Limits};
use crate::{Control, Scene, origin};

const PAGE: &str = include_str!("../assets/index.html");
const SCRIPT: &str = include_str!("../assets/viewer.js");

/// Frames are encoded at most this often; camera images at most every `IMAGE_EVERY`.
const FRAME_EVERY: Duration = Duration::from_millis(40);
const IMAGE_EVERY: Duration = Duration::from_millis(150);

/// What every browser is sent: the newest frame and the newest images.
#[derive(Default)]
struct Encoded {
    frame: Option<Arc<str>>,
    /// Increases when `frame` changes.
    frame_seq: u64,
    images: Option<Arc<Vec<Vec<u8>>>>,
    /// The shape over those images (text, sent after them): drawn over the frame it belongs
    /// to, not over the newest frame's figures.
    overlays: Option<Arc<str>>,
    /// Increases when `images` changes.
    image_seq: u64,
}

#[derive(Clone)]
struct AppState {
    hello: Arc<str>,
    encoded: watch::Receiver<Arc<Encoded>>,
    /// How often a WebSocket is pinged: well within the idle limit.
    ping: Duration,
    /// Where a replay's controls go (none for a live viewer).
    controls: Option<std::sync::mpsc::Sender<Control>>,
}

/// Serves until the process ends.
pub(crate) async fn serve(
    listener: std::net::TcpListener,
    scene: Scene,
    updates: watch::Receiver<Option<Arc<Update>>>,
    limits: Limits,
    controls: Option<std::sync::mpsc::Sender<Control>>,
) {
    let hello = serde_json::json!({"type": "hello", "scene": scene}).to_string();
    let (encoded_tx, encoded) = watch::channel(Arc::new(Encoded::default()));
    tokio::spawn(encode_newest(updates, encoded_tx));
    let state = AppState {
        hello: hello.into(),
        encoded,
        ping: limits.idle() / 3,
        controls,
    };
    let guard = match listener.local_addr() {
        Ok(a) => origin::Guard {
            port: a.port(),
            loopback: a.ip().is_loopback(),
        },
        Err(e) => {
            tracing::error!("viewer: cannot listen: {e}");
            return;
        }
    };
    let app = Router::new()
        .route("/", get(|| async { Html(PAGE) }))
        .route(
            "/viewer.js",
            get(|| async { ([(header::CONTENT_TYPE, "text/javascript")], SCRIPT) }),
        )
        .route("/health", get(|| async { "ok" }))
        .route("/ws", get(socket))
        .layer(axum::middleware::from_fn_with_state(guard, checked))
        .with_state(state);
    let listener = match tokio::net::TcpListener::from_std(listener) {
        Ok(l) => l,
        Err(e) => {
            tracing::error!("viewer: cannot listen: {e}");
            return;
        }
    };
    if let Err(e) = axum::serve(Limited::new(listener, limits), app).await {
        tracing::error!("viewer: server stopped: {e}");
    }
}

/// Refuses a request whose `Host` or `Origin` is not the viewer's own (see `origin`).
async fn checked(
    State(guard): State<origin::Guard>,
    request: axum::extract::Request,
    next: axum::middleware::Next,
) -> axum::response::Response {
    let allowed = {
        let headers = request.headers();
        let value = |name| headers.get(name).and_then(|v| v.to_str().ok());
        guard.allows(value(header::HOST), value(header::ORIGIN))
    };
    if allowed {
        next.run(request).await
    } else {
        (
            axum::http::StatusCode::FORBIDDEN,
            "the viewer serves its own page only (Host or Origin not allowed)",
        )
            .into_response()
    }
}

/// Encodes the newest update at a capped rate, on a blocking thread. Images go at most every
/// `IMAGE_EVERY`; when the newest update's were skipped for that, they follow once the interval
/// has passed, even if no newer update comes (a paused replay, the last frame of a run): the
/// page never keeps showing an older frame's images under the newest shape.
async fn encode_newest(
    mut updates: watch::Receiver<Option<Arc<Update>>>,
    out: watch::Sender<Arc<Encoded>>,
) {
    let mut last_images = tokio::time::Instant::now() - IMAGE_EVERY;
    let (mut frame_seq, mut image_seq) = (0, 0);
    let mut frame: Option<Arc<str>> = None;
    let mut images: Option<Arc<Vec<Vec<u8>>>> = None;
    let mut overlays: Option<Arc<str>> = None;
    let mut newest: Option<Arc<Update>> = None;
    let mut images_behind = false;
    loop {
        let fresh = if images_behind {
            tokio::select! {
                changed = updates.changed() => changed.is_ok().then_some(true),
                _ = tokio::time::sleep_until(last_images + IMAGE_EVERY) => Some(false),
            }
        } else {
            updates.changed().await.is_ok().then_some(true)
        };
        let Some(fresh) = fresh else {
            return;
        };
        if fresh {
            newest = updates.borrow_and_update().clone();
        }
        let Some(update) = newest.clone() else {
            continue;
        };
        let with_images = last_images.elapsed() >= IMAGE_EVERY;
        let encoded = tokio::task::spawn_blocking(move || {
            let json: Option<Arc<str>> = fresh.then(|| frame_json(&update).into());
            let imgs = with_images.then(|| {
                let shape = overlays_json(&update).map(Arc::from);
                (Arc::new(image_messages(&update)), shape)
            });
            (json, imgs)
        })
        .await;
        let Ok((json, new_images)) = encoded else {
            continue;
        };
        if let Some(json) = json {
            frame = Some(json);
            frame_seq += 1;
        }
        images_behind = new_images.is_none();
        if let Some((i, shape)) = new_images {
            images = Some(i);
            overlays = shape;
            image_seq += 1;
            last_images = tokio::time::Instant::now();
        }
        out.send_replace(Arc::new(Encoded {
            frame: frame.clone(),
            frame_seq,
            images: images.clone(),
            overlays: overlays.clone(),
            image_seq,
        }));
        tokio::time::sleep(FRAME_EVERY).await;
    }
}

async fn socket(ws: WebSocketUpgrade, State(state): State<AppState>) -> impl IntoResponse {
    ws.on_upgrade(move |socket| stream(socket, state))
}

/// Sends the scene, then the newest frame whenever there is a newer one than the last sent;
/// reads what the browser sends (answering pings, ending on its close) and pings it while
/// no frames come, so that the connection never idles out.
async fn stream(mut socket: WebSocket, state: AppState) {
    let AppState {
        hello,
        mut encoded,
        ping,
        controls,
    } = state;
    if socket
        .send(Message::Text(hello.as_ref().into()))
        .await
        .is_err()
    {
        return;
    }
    let (mut sent_frame, mut sent_images) = (0, 0);
    let mut pings = tokio::time::interval(ping);
    pings.tick().await;
    loop {
        let newest = encoded.borrow_and_update().clone();
        if newest.frame_seq != sent_frame
            && let Some(frame) = &newest.frame
        {
            if socket
                .send(Message::Text(frame.as_ref().into()))
                .await
                .is_err()
            {
                return;
            }
            sent_frame = newest.frame_seq;
        }
        if newest.image_seq != sent_images
            && let Some(images) = &newest.images
        {
            for image in images.iter() {
                if socket
                    .send(Message::Binary(image.clone().into()))
                    .await
                    .is_err()
                {
                    return;
                }
            }
            if let Some(shape) = &newest.overlays
                && socket
                    .send(Message::Text(shape.as_ref().into()))
                    .await
                    .is_err()
            {
                return;
            }
            sent_images = newest.image_seq;
        }
        // Until there is a newer frame: the browser's messages (a ping is answered as it is
        // read), and our pings.
        loop {
            tokio::select! {
                changed = encoded.changed() => {
                    if changed.is_err() {
                        return;
                    }
                    break;
                }
                message = socket.recv() => match message {
                    Some(Ok(Message::Close(_))) | Some(Err(_)) | None => return,
                    Some(Ok(Message::Text(text))) => {
                        // A replay's control; anything else a page sends is ignored.
                        if let (Some(tx), Ok(control)) =
                            (&controls, serde_json::from_str::<Control>(text.as_str()))
                        {
                            let _ = tx.send(control);
                        }
                    }
                    Some(Ok(_)) => {}
                },
                _ = pings.tick() => {
                    if socket.send(Message::Ping(Vec::new().into())).await.is_err() {
                        return;
                    }
                }
            }
        }
    }
}
