//! The viewer's HTTP + WebSocket server (axum). Every route needs the
//! token (`?token=T`, or the cookie the page's first load sets so that its
//! modules load): without it, or with a wrong one, 403 and nothing served.
//!
//! - `GET /` the page; `GET /assets/NAME` its modules and style;
//! - `GET /ws` the WebSocket: the page sends [`super::messages`] (text,
//!   at most [`MAX_MESSAGE_BYTES`]); the server sends `hello` once, then
//!   per frame a text message (JSON: `seq`, `scale`, timings) followed by
//!   the frame itself as a binary message, and `error` messages;
//! - `GET /frame.png` the last full-resolution frame (the PNG `pvrsim
//!   render` writes), `GET /scene.toml` its scene (the current view and
//!   transfer function), `GET /state.json` the camera, the last frame's
//!   timings, per-node figures and fps; `GET /movie.mp4` the last movie
//!   recorded ([`super::movie`]).

use std::collections::HashMap;
use std::sync::Arc;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use tokio::sync::broadcast;

use super::messages::{self, MAX_MESSAGE_BYTES};
use super::shared::{Outgoing, Shared};

/// Whether the request carries the token (query or cookie).
fn authorized(s: &Shared, q: &HashMap<String, String>, headers: &HeaderMap) -> bool {
    if let Some(t) = q.get("token") {
        return eq(t.as_bytes(), s.token.as_bytes());
    }
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|kv| kv.trim().split_once('='))
        .any(|(k, v)| k == s.cookie && eq(v.as_bytes(), s.token.as_bytes()))
}

/// Compares in time independent of where the bytes differ.
fn eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

type Q = Query<HashMap<String, String>>;

fn forbidden() -> Response {
    (
        StatusCode::FORBIDDEN,
        "403: this viewer needs its token: open the URL `pvrsim view` printed (?token=...)\n",
    )
        .into_response()
}

async fn index(State(s): State<Arc<Shared>>, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return forbidden();
    }
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8".to_string()),
            (
                header::SET_COOKIE,
                format!(
                    "{}={}; HttpOnly; SameSite=Strict; Path=/",
                    s.cookie, s.token
                ),
            ),
            (header::CACHE_CONTROL, "no-store".to_string()),
        ],
        super::assets::INDEX_HTML,
    )
        .into_response()
}

async fn asset(
    State(s): State<Arc<Shared>>,
    Path(name): Path<String>,
    Query(q): Q,
    h: HeaderMap,
) -> Response {
    if !authorized(&s, &q, &h) {
        return forbidden();
    }
    match super::assets::get(&name) {
        Some((mime, body)) => ([(header::CONTENT_TYPE, mime)], body).into_response(),
        None => (StatusCode::NOT_FOUND, "no such asset\n").into_response(),
    }
}

async fn frame_png(State(s): State<Arc<Shared>>, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return forbidden();
    }
    let png = tokio::task::spawn_blocking(move || s.full_png()).await;
    match png {
        Ok(Some(Ok(png))) => (
            [
                (header::CONTENT_TYPE, "image/png"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            png.as_ref().clone(),
        )
            .into_response(),
        Ok(Some(Err(e))) => (
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("cannot write the PNG: {e:#}\n"),
        )
            .into_response(),
        Ok(None) | Err(_) => (
            StatusCode::SERVICE_UNAVAILABLE,
            "no full-resolution frame yet\n",
        )
            .into_response(),
    }
}

async fn scene_toml(State(s): State<Arc<Shared>>, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return forbidden();
    }
    match s.last().toml.clone() {
        Some(t) => (
            [
                (header::CONTENT_TYPE, "application/toml"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            t,
        )
            .into_response(),
        None => (
            StatusCode::SERVICE_UNAVAILABLE,
            "no full-resolution frame yet\n",
        )
            .into_response(),
    }
}

async fn state_json(State(s): State<Arc<Shared>>, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return forbidden();
    }
    let st = s.last().state.clone();
    (
        [
            (header::CONTENT_TYPE, "application/json"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        st.to_string(),
    )
        .into_response()
}

async fn ws(
    State(s): State<Arc<Shared>>,
    Query(q): Q,
    h: HeaderMap,
    up: Result<WebSocketUpgrade, axum::extract::ws::rejection::WebSocketUpgradeRejection>,
) -> Response {
    // The token first: a request without it gets 403 whether or not it is
    // a WebSocket handshake.
    if !authorized(&s, &q, &h) {
        return forbidden();
    }
    match up {
        Ok(up) => up
            .max_message_size(MAX_MESSAGE_BYTES)
            .max_frame_size(MAX_MESSAGE_BYTES)
            .on_upgrade(move |socket| session(socket, s)),
        Err(e) => e.into_response(),
    }
}

/// One page's WebSocket: `hello`, the last frame, then every new frame;
/// its messages validated and handed to the render loop.
async fn session(mut socket: WebSocket, s: Arc<Shared>) {
    let mut frames = s.frames.subscribe();
    let mut closing = s.closing.subscribe();
    let hello = {
        let mut v = serde_json::to_value(s.info()).unwrap_or_default();
        v["type"] = "hello".into();
        v
    };
    if socket
        .send(Message::Text(hello.to_string().into()))
        .await
        .is_err()
    {
        return;
    }
    let last = s.last().frame.clone();
    if let Some(f) = last {
        if send(&mut socket, &f).await.is_err() {
            return;
        }
    }
    loop {
        tokio::select! {
            _ = closing.changed() => {
                let _ = socket.send(Message::Close(None)).await;
                return;
            }
            f = frames.recv() => match f {
                Ok(f) => if send(&mut socket, &f).await.is_err() { return },
                Err(broadcast::error::RecvError::Lagged(_)) => continue,
                Err(broadcast::error::RecvError::Closed) => return,
            },
            m = socket.recv() => match m {
                Some(Ok(Message::Text(t))) => match accept(&s, t.as_str()) {
                    Ok(()) => {}
                    Err(e) => {
                        let err = Outgoing::error(e);
                        if socket.send(Message::Text(err.meta.into())).await.is_err() {
                            return;
                        }
                    }
                },
                Some(Ok(Message::Binary(_))) => {
                    let err = Outgoing::error("binary messages are not understood: send JSON text".into());
                    if socket.send(Message::Text(err.meta.into())).await.is_err() {
                        return;
                    }
                }
                Some(Ok(_)) => {}
                Some(Err(_)) | None => return,
            },
        }
    }
}

/// A page's text message: parsed, checked against the data (fields, time
/// steps), handed to the movie recorder or the render loop.
fn accept(s: &Arc<Shared>, text: &str) -> Result<(), String> {
    let m = messages::parse(text)?;
    {
        let info = s.info();
        messages::check_data(&m, &info.fields, info.steps.len())?;
    }
    match m {
        messages::ClientMessage::Movie(action) => s.movie(action),
        m => {
            s.request(m);
            Ok(())
        }
    }
}

async fn movie_mp4(State(s): State<Arc<Shared>>, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return forbidden();
    }
    match s.movie_bytes() {
        Some(m) => (
            [
                (header::CONTENT_TYPE, "video/mp4"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            m.as_ref().clone(),
        )
            .into_response(),
        None => (
            StatusCode::NOT_FOUND,
            "no movie recorded yet: Record movie, then Stop, in the page\n",
        )
            .into_response(),
    }
}

async fn send(socket: &mut WebSocket, f: &Outgoing) -> Result<(), axum::Error> {
    socket.send(Message::Text(f.meta.clone().into())).await?;
    if let Some(b) = &f.bytes {
        socket.send(Message::Binary(b.clone().into())).await?;
    }
    Ok(())
}

/// Serves until `stop` fires or Ctrl-C.
pub async fn serve(
    listener: std::net::TcpListener,
    shared: Arc<Shared>,
    stop: tokio::sync::oneshot::Receiver<()>,
) -> anyhow::Result<()> {
    let app = Router::new()
        .route("/", get(index))
        .route("/assets/{name}", get(asset))
        .route("/ws", get(ws))
        .route("/frame.png", get(frame_png))
        .route("/scene.toml", get(scene_toml))
        .route("/state.json", get(state_json))
        .route("/movie.mp4", get(movie_mp4))
        .with_state(shared.clone());
    let listener = tokio::net::TcpListener::from_std(listener)?;
    axum::serve(listener, app)
        .with_graceful_shutdown(async move {
            tokio::select! {
                _ = stop => {}
                _ = tokio::signal::ctrl_c() => {}
            }
            // Open WebSockets end too (graceful shutdown waits for them).
            shared.closing.send_replace(true);
        })
        .await?;
    Ok(())
}
