//! The viewer's render loop, on a thread of its own that owns the backend:
//!
//! - **newest wins**: the page's inputs are merged into one pending request
//!   (a newer camera replaces an older one, never queued);
//! - **at most one frame in flight**: the loop takes the pending request,
//!   renders and sends it, then looks again;
//! - **nothing while idle**: with nothing pending the loop sleeps on a
//!   condition variable (no timer, no polling);
//! - **reduced while interacting**: an input marked `interacting` is drawn
//!   at `1/s` of the size (`--interactive-scale`; `auto`: the level
//!   [`Pace`] chooses, maybe of a coarse stand-in of the mesh), and a full
//!   frame follows
//!   [`SETTLE`] after the last input (or at once when the page says the
//!   drag ended).

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::backend::{Backend, Rendered};
use super::encode::{self, FrameFormat};
use super::pace::{Level, Pace};
use super::shared::{scene_json, Outgoing, Shared};
use super::InteractiveScale;
use crate::job::render::RendererKind;
use crate::job::ViewChange;

/// How long after the last interactive input the full frame is drawn.
pub const SETTLE: Duration = Duration::from_millis(150);

/// One piece of work taken from [`Pending`].
struct Work {
    change: ViewChange,
    ert: Option<f64>,
    renderer: Option<RendererKind>,
    field: Option<String>,
    step: Option<usize>,
    interacting: bool,
    input: u64,
}

/// Waits for the next piece of work (`None`: shut down).
fn next(shared: &Shared) -> Option<Work> {
    let mut p = shared.pending.lock().unwrap_or_else(|e| e.into_inner());
    loop {
        if p.shutdown {
            return None;
        }
        if p.dirty {
            p.dirty = false;
            if !p.interacting {
                p.need_full = false;
            }
            return Some(Work {
                change: std::mem::take(&mut p.change),
                ert: p.ert.take(),
                renderer: p.renderer.take(),
                field: p.field.take(),
                step: p.step.take(),
                interacting: p.interacting,
                input: p.input,
            });
        }
        if p.need_full {
            let since = p.last_input.elapsed();
            if since >= SETTLE {
                p.need_full = false;
                p.interacting = false;
                return Some(Work {
                    change: ViewChange::default(),
                    ert: None,
                    renderer: None,
                    field: None,
                    step: None,
                    interacting: false,
                    input: p.input,
                });
            }
            p = shared
                .wake
                .wait_timeout(p, SETTLE - since)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        } else {
            p = shared.wake.wait(p).unwrap_or_else(|e| e.into_inner());
        }
    }
}

/// Starts the loop on its own thread; it ends when [`Shared::shut_down`]
/// is called.
pub fn spawn(
    backend: Box<dyn Backend>,
    shared: Arc<Shared>,
    scale: InteractiveScale,
) -> std::thread::JoinHandle<anyhow::Result<()>> {
    std::thread::Builder::new()
        .name("pvrsim-view-render".into())
        .spawn(move || run(backend, &shared, scale))
        .expect("a thread for the render loop")
}

fn run(
    mut backend: Box<dyn Backend>,
    shared: &Shared,
    scale: InteractiveScale,
) -> anyhow::Result<()> {
    let mut seq = 0u64;
    let mut pace = Pace::new(scale, backend.has_coarse());
    let mut shown: VecDeque<Instant> = VecDeque::new();
    let mut step_shown = 0usize;
    while let Some(w) = next(shared) {
        if let Err(e) = backend.apply(&w.change) {
            shared.send(Outgoing::error(format!("{e:#}")));
            continue;
        }
        if w.field.is_some() || w.step.is_some() {
            if let Err(e) = backend.select(w.step, w.field.as_deref()) {
                shared.send(Outgoing::error(format!("{e:#}")));
                continue;
            }
            let info = backend.info();
            step_shown = info.step;
            let mut note = serde_json::to_value(&info).unwrap_or_default();
            note["type"] = "data".into();
            shared.set_info(info);
            shared.send(Outgoing::note(note));
        }
        if w.ert.is_some() || w.renderer.is_some() {
            if let Err(e) = backend.set_options(w.ert, w.renderer) {
                shared.send(Outgoing::error(format!("{e:#}")));
                continue;
            }
        }
        let level = if w.interacting {
            pace.choose()
        } else {
            Level::FULL
        };
        let format = if w.interacting {
            FrameFormat::Jpeg
        } else {
            FrameFormat::Png
        };
        let Rendered {
            image,
            render_s,
            nodes,
            cells,
        } = match backend.frame(level) {
            Ok(r) => r,
            Err(e) => {
                shared.send(Outgoing::error(format!("{e:#}")));
                continue;
            }
        };
        let t = Instant::now();
        let bytes = match encode::encode(&image, format) {
            Ok(b) => b,
            Err(e) => {
                shared.send(Outgoing::error(format!("encoding the frame: {e:#}")));
                continue;
            }
        };
        let encode_s = t.elapsed().as_secs_f64();
        pace.record(level, render_s + encode_s);
        let divisor = level.divisor;
        seq += 1;
        let now = Instant::now();
        shown.push_back(now);
        while shown.len() > 1 && now.duration_since(shown[0]) > Duration::from_secs(2) {
            shown.pop_front();
        }
        let fps = if shown.len() > 1 {
            (shown.len() - 1) as f64 / now.duration_since(shown[0]).as_secs_f64().max(1e-9)
        } else {
            0.0
        };
        let scene = backend.scene();
        let meta = serde_json::json!({
            "type": "frame",
            "seq": seq,
            "scale": divisor,
            "coarse": level.coarse,
            "cells": cells,
            "field": scene.data.field,
            "step": step_shown,
            "width": image.width,
            "height": image.height,
            "format": format.mime(),
            "input": w.input,
            "render_ms": 1e3 * render_s,
            "encode_ms": 1e3 * encode_s,
            "bytes": bytes.len(),
            "fps": fps,
            "nodes": nodes,
            "scene": scene_json(scene),
        });
        shared.set_state(serde_json::json!({
            "seq": seq,
            "scale": divisor,
            "coarse": level.coarse,
            "cells": cells,
            "interacting": w.interacting,
            "camera": meta["scene"]["camera"].clone(),
            "render_ms": 1e3 * render_s,
            "encode_ms": 1e3 * encode_s,
            "fps": fps,
            "nodes": meta["nodes"].clone(),
            "options": backend.command_options(),
            "field": scene.data.field,
            "step": step_shown,
        }));
        if format == FrameFormat::Png {
            let data_path =
                std::fs::canonicalize(&scene.data.path).unwrap_or_else(|_| scene.data.path.clone());
            shared.set_full(image, scene.to_toml(&data_path.to_string_lossy()));
            shared.sent_full(Arc::new(bytes.clone()));
        }
        shared.send(Outgoing::frame(meta, bytes));
    }
    Ok(())
}
