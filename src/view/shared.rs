//! The state the viewer's server tasks and its render loop share: the
//! pending request ([`Pending`], newest wins), the condition variable that
//! wakes the loop, the channel that carries frames to every page
//! ([`Outgoing`]) and what the last frame left for the HTTP routes.

use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

use tokio::sync::broadcast;

use super::backend::Info;
use super::messages::{ClientMessage, MovieAction};
use super::movie::Recorder;
use crate::job::render::RendererKind;
use crate::job::ViewChange;
use crate::scene::camera::Projection;
use crate::scene::Scene;

/// What the page asked for since the loop last looked.
pub struct Pending {
    pub(super) change: ViewChange,
    pub(super) ert: Option<f64>,
    pub(super) renderer: Option<RendererKind>,
    pub(super) field: Option<String>,
    pub(super) step: Option<usize>,
    pub(super) dirty: bool,
    pub(super) interacting: bool,
    pub(super) input: u64,
    pub(super) last_input: Instant,
    pub(super) need_full: bool,
    pub(super) shutdown: bool,
}

impl Default for Pending {
    fn default() -> Self {
        Pending {
            change: ViewChange::default(),
            ert: None,
            renderer: None,
            field: None,
            step: None,
            // The first frame is drawn as soon as the loop starts.
            dirty: true,
            interacting: false,
            input: 0,
            last_input: Instant::now(),
            need_full: false,
            shutdown: false,
        }
    }
}

impl Pending {
    /// Merges a validated message: the newest camera and transfer function
    /// replace older ones not yet drawn.
    pub fn merge(&mut self, m: ClientMessage) {
        match m {
            ClientMessage::View {
                camera,
                transfer,
                interacting,
                input,
            } => {
                if camera.is_some() {
                    self.change.camera = camera;
                }
                if transfer.is_some() {
                    self.change.transfer = transfer;
                }
                self.interacting = interacting;
                self.input = input;
                if interacting {
                    self.need_full = true;
                }
            }
            ClientMessage::Options {
                ert,
                renderer,
                input,
            } => {
                self.ert = ert.or(self.ert);
                self.renderer = renderer.or(self.renderer);
                self.interacting = false;
                self.input = input;
            }
            ClientMessage::Data { field, step, input } => {
                self.field = field.or(self.field.take());
                self.step = step.or(self.step);
                self.interacting = false;
                self.input = input;
            }
            // The recorder's, not the render loop's.
            ClientMessage::Movie(_) => return,
        }
        self.dirty = true;
        self.last_input = Instant::now();
    }

    /// Ends the loop at its next look.
    pub fn shut_down(&mut self) {
        self.shutdown = true;
    }
}

/// A message to every connected page.
#[derive(Debug)]
pub struct Outgoing {
    /// The JSON text message.
    pub meta: String,
    /// The frame's bytes (sent as a binary message after `meta`), if any.
    pub bytes: Option<Vec<u8>>,
}

impl Outgoing {
    /// A frame: its description and its encoded bytes.
    pub fn frame(meta: serde_json::Value, bytes: Vec<u8>) -> Outgoing {
        Outgoing {
            meta: meta.to_string(),
            bytes: Some(bytes),
        }
    }

    /// A status message (JSON) to every page, no frame.
    pub fn note(meta: serde_json::Value) -> Outgoing {
        Outgoing {
            meta: meta.to_string(),
            bytes: None,
        }
    }

    /// An error the page shows.
    pub fn error(message: String) -> Outgoing {
        Outgoing {
            meta: serde_json::json!({"type": "error", "message": message}).to_string(),
            bytes: None,
        }
    }
}

/// What the last full-resolution frame left for the HTTP routes.
#[derive(Default)]
pub(super) struct Last {
    pub(super) full: Option<Arc<crate::image::Image>>,
    pub(super) png: Option<Arc<Vec<u8>>>,
    pub(super) toml: Option<String>,
    pub(super) state: serde_json::Value,
    pub(super) frame: Option<Arc<Outgoing>>,
    /// The lossless PNG of the last full frame sent (a movie's first).
    pub(super) full_sent: Option<Arc<Vec<u8>>>,
}

/// State shared by the server's tasks and the render loop.
pub struct Shared {
    pub(super) token: String,
    pub(super) cookie: String,
    pub(super) info: Mutex<Info>,
    /// The request the render loop draws next.
    pub pending: Mutex<Pending>,
    /// Wakes the render loop.
    pub wake: Condvar,
    pub(super) frames: broadcast::Sender<Arc<Outgoing>>,
    pub(super) last: Mutex<Last>,
    pub(super) closing: tokio::sync::watch::Sender<bool>,
    pub(super) recorder: Mutex<Recorder>,
}

impl Shared {
    /// The state of a server with `token` on `port`.
    pub fn new(token: String, port: u16, info: Info) -> Shared {
        Shared {
            token,
            cookie: format!("pvrsim_view_{port}"),
            info: Mutex::new(info),
            pending: Mutex::new(Pending::default()),
            wake: Condvar::new(),
            frames: broadcast::channel(16).0,
            last: Mutex::new(Last::default()),
            closing: tokio::sync::watch::channel(false).0,
            recorder: Mutex::new(Recorder::default()),
        }
    }

    /// What a page is told when it connects (the field and time step
    /// shown now).
    pub fn info(&self) -> Info {
        self.info.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Records a new field or time step (pages connecting later are told).
    pub fn set_info(&self, info: Info) {
        *self.info.lock().unwrap_or_else(|e| e.into_inner()) = info;
    }

    fn recorder(&self) -> std::sync::MutexGuard<'_, Recorder> {
        self.recorder.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Keeps the lossless PNG of a full frame sent: the next movie's first
    /// frame, and a frame of the movie being recorded.
    pub fn sent_full(&self, png: Arc<Vec<u8>>) {
        self.last().full_sent = Some(png.clone());
        let said = self.recorder().add(png);
        if let Some(m) = said {
            self.send(Outgoing::error(m));
        }
    }

    /// The page's "Record movie": starts keeping the full frames shown
    /// (ffmpeg must be on PATH to make the movie: refused, saying so,
    /// otherwise) or stops and writes the movie on a thread of its own,
    /// telling every page when `GET /movie.mp4` serves it.
    pub fn movie(self: &Arc<Self>, action: MovieAction) -> Result<(), String> {
        match action {
            MovieAction::Start => {
                if !crate::job::series::args::ffmpeg_found() {
                    return Err("Record movie: ffmpeg is not on PATH on the machine running                                 pvrsim view, so no movie can be made (install ffmpeg; Record                                 series works without it)"
                        .into());
                }
                let current = self.last().full_sent.clone();
                let mut r = self.recorder();
                r.start(current)?;
                let n = r.frames();
                drop(r);
                self.send(Outgoing::note(
                    serde_json::json!({"type": "movie", "state": "recording", "frames": n}),
                ));
                Ok(())
            }
            MovieAction::Stop => {
                let frames = self.recorder().stop()?;
                self.send(Outgoing::note(serde_json::json!({
                    "type": "movie", "state": "writing", "frames": frames.len()
                })));
                let me = self.clone();
                std::thread::Builder::new()
                    .name("pvrsim-view-movie".into())
                    .spawn(move || match super::movie::write(&frames) {
                        Ok(bytes) => {
                            let n = bytes.len();
                            me.recorder().movie = Some(Arc::new(bytes));
                            me.send(Outgoing::note(serde_json::json!({
                                "type": "movie", "state": "ready", "frames": frames.len(),
                                "bytes": n, "url": "movie.mp4"
                            })));
                        }
                        Err(e) => me.send(Outgoing::error(format!("movie: {e:#}"))),
                    })
                    .map_err(|e| format!("movie: no thread to write it: {e}"))?;
                Ok(())
            }
        }
    }

    /// The last movie recorded.
    pub(super) fn movie_bytes(&self) -> Option<Arc<Vec<u8>>> {
        self.recorder().movie.clone()
    }

    /// The last frame's records.
    pub(super) fn last(&self) -> std::sync::MutexGuard<'_, Last> {
        self.last.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Sends to every page (a page that lags skips to the newest).
    pub fn send(&self, m: Outgoing) {
        let m = Arc::new(m);
        if m.bytes.is_some() {
            self.last().frame = Some(m.clone());
        }
        let _ = self.frames.send(m);
    }

    /// Records the last frame's state (`/state.json`).
    pub fn set_state(&self, state: serde_json::Value) {
        self.last().state = state;
    }

    /// Records the last full-resolution frame and its scene (its PNG is
    /// written when `/frame.png` is first asked for).
    pub fn set_full(&self, image: crate::image::Image, toml: String) {
        let mut l = self.last();
        l.full = Some(Arc::new(image));
        l.png = None;
        l.toml = Some(toml);
    }

    /// The last full frame as `pvrsim render` writes it.
    /// The last full frame's PNG, written on the first ask.
    pub(super) fn full_png(&self) -> Option<anyhow::Result<Arc<Vec<u8>>>> {
        let (full, png) = {
            let l = self.last();
            (l.full.clone()?, l.png.clone())
        };
        if let Some(p) = png {
            return Some(Ok(p));
        }
        let bytes = match full.png_bytes() {
            Ok(b) => Arc::new(b),
            Err(e) => return Some(Err(e.into())),
        };
        let mut l = self.last();
        if l.full.as_ref().is_some_and(|f| Arc::ptr_eq(f, &full)) {
            l.png = Some(bytes.clone());
        }
        Some(Ok(bytes))
    }

    /// Hands a validated message to the render loop.
    pub fn request(&self, m: ClientMessage) {
        self.pending
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .merge(m);
        self.wake.notify_one();
    }

    /// Ends the render loop.
    pub fn shut_down(&self) {
        self.pending
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .shut_down();
        self.wake.notify_one();
    }
}

/// The scene's camera, transfer function and image as the page reads them.
pub fn scene_json(s: &Scene) -> serde_json::Value {
    let c = &s.camera;
    let mut cam = serde_json::json!({"eye": c.eye, "target": c.target, "up": c.up});
    match c.projection {
        Projection::Orthographic { height } => {
            cam["projection"] = "orthographic".into();
            cam["height"] = height.into();
        }
        Projection::Perspective { fov_y_deg } => {
            cam["projection"] = "perspective".into();
            cam["fov_y_deg"] = fov_y_deg.into();
        }
    }
    let points: Vec<[f64; 5]> = s
        .transfer
        .points
        .iter()
        .map(|p| [p.s, p.rgb[0], p.rgb[1], p.rgb[2], p.opacity])
        .collect();
    serde_json::json!({
        "camera": cam,
        "transfer": {"points": points, "unit_distance": s.transfer.unit_distance},
        "image": {"width": s.image.width, "height": s.image.height},
    })
}
