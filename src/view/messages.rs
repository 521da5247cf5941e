//! What the page sends over the WebSocket, parsed and validated once:
//! a message is at most [`MAX_MESSAGE_BYTES`], JSON, one of the kinds of
//! [`ClientMessage`]; a camera is checked as a scene file's is, a transfer
//! function as the scene contract's `[transfer]` table, renderer names
//! and the ERT threshold as the command line's. A refusal is a sentence the
//! page shows; the server keeps serving.

use serde::Deserialize;

use crate::job::render::RendererKind;
use crate::scene::camera::{Camera, Projection};
use crate::scene::TransferFunction;

/// The largest WebSocket message the server reads (a transfer function of
/// a few hundred points fits many times over).
pub const MAX_MESSAGE_BYTES: usize = 64 * 1024;

/// The most control points a transfer function from the page may have.
pub const MAX_TRANSFER_POINTS: usize = 256;

/// A camera as the page sends it (the scene contract's `[camera]`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraMsg {
    eye: [f64; 3],
    target: [f64; 3],
    up: [f64; 3],
    projection: String,
    height: Option<f64>,
    fov_y_deg: Option<f64>,
}

/// A transfer function as the page sends it (rows `[s, r, g, b, opacity]`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferMsg {
    points: Vec<Vec<f64>>,
    unit_distance: f64,
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum RawMessage {
    View {
        camera: Option<CameraMsg>,
        transfer: Option<TransferMsg>,
        #[serde(default)]
        interacting: bool,
        #[serde(default)]
        input: u64,
    },
    Options {
        ert: Option<f64>,
        renderer: Option<String>,
        #[serde(default)]
        input: u64,
    },
    Data {
        field: Option<String>,
        step: Option<u64>,
        #[serde(default)]
        input: u64,
    },
    Movie {
        action: String,
        #[serde(default)]
        #[allow(dead_code)]
        input: u64,
    },
}

/// What the page asks of the movie recorder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MovieAction {
    /// Start keeping the full-resolution frames shown.
    Start,
    /// Stop and write the movie of the frames kept.
    Stop,
}

/// A validated message from the page.
#[derive(Debug, Clone)]
pub enum ClientMessage {
    /// A new camera and/or transfer function.
    View {
        /// The camera (checked).
        camera: Option<Camera>,
        /// The transfer function (checked).
        transfer: Option<TransferFunction>,
        /// True while the user drags or scrolls (a reduced frame will do).
        interacting: bool,
        /// The page's number for this input (echoed in the frame it
        /// produced: the page measures input-to-frame latency with it).
        input: u64,
    },
    /// Render options: the ERT threshold, the renderer.
    Options {
        /// ERT threshold in (0, 1].
        ert: Option<f64>,
        /// The renderer.
        renderer: Option<RendererKind>,
        /// The page's input number.
        input: u64,
    },
    /// Another field and/or time step (checked against the data's by
    /// [`check_data`]).
    Data {
        /// The point field's name.
        field: Option<String>,
        /// The time step's index.
        step: Option<usize>,
        /// The page's input number.
        input: u64,
    },
    /// Start or stop recording a movie.
    Movie(MovieAction),
}

/// The longest field name a message may carry.
pub const MAX_FIELD_NAME: usize = 256;

/// Checks a [`ClientMessage::Data`] against the data's `fields` and its
/// number of time `steps` (a refusal the page shows; other messages pass).
pub fn check_data(m: &ClientMessage, fields: &[String], steps: usize) -> Result<(), String> {
    let ClientMessage::Data { field, step, .. } = m else {
        return Ok(());
    };
    if let Some(f) = field {
        if !fields.contains(f) {
            return Err(crate::job::render::loaded::unknown_field(f, fields));
        }
    }
    if let Some(k) = step {
        if *k >= steps {
            return Err(crate::job::render::loaded::no_such_step(*k, steps));
        }
    }
    Ok(())
}

/// Parses and validates one text message.
pub fn parse(text: &str) -> Result<ClientMessage, String> {
    if text.len() > MAX_MESSAGE_BYTES {
        return Err(format!(
            "message of {} bytes exceeds the limit of {MAX_MESSAGE_BYTES} bytes",
            text.len()
        ));
    }
    let raw: RawMessage =
        serde_json::from_str(text).map_err(|e| format!("malformed message: {e}"))?;
    Ok(match raw {
        RawMessage::View {
            camera,
            transfer,
            interacting,
            input,
        } => ClientMessage::View {
            camera: camera.map(|c| camera_of(&c)).transpose()?,
            transfer: transfer.map(|t| transfer_of(&t)).transpose()?,
            interacting,
            input,
        },
        RawMessage::Options {
            ert,
            renderer,
            input,
        } => {
            if let Some(t) = ert {
                if !(t > 0.0 && t <= 1.0) {
                    return Err(format!("ERT threshold must be in (0, 1], got {t}"));
                }
            }
            let renderer = renderer
                .map(|r| {
                    <RendererKind as clap::ValueEnum>::from_str(&r, false)
                        .map_err(|_| format!("unknown renderer \"{r}\""))
                })
                .transpose()?;
            ClientMessage::Options {
                ert,
                renderer,
                input,
            }
        }
        RawMessage::Data { field, step, input } => {
            if let Some(f) = &field {
                if f.is_empty() || f.len() > MAX_FIELD_NAME {
                    return Err(format!(
                        "field: must name a point field (1 to {MAX_FIELD_NAME} bytes)"
                    ));
                }
            }
            step_index(step).map(|step| ClientMessage::Data { field, step, input })?
        }
        RawMessage::Movie { action, .. } => ClientMessage::Movie(match action.as_str() {
            "start" => MovieAction::Start,
            "stop" => MovieAction::Stop,
            other => {
                return Err(format!(
                    "movie.action: must be \"start\" or \"stop\", got \"{other}\""
                ))
            }
        }),
    })
}

/// A time step's index as a `usize`.
fn step_index(step: Option<u64>) -> Result<Option<usize>, String> {
    step.map(|k| usize::try_from(k).map_err(|_| format!("time step {k} does not exist")))
        .transpose()
}

fn camera_of(c: &CameraMsg) -> Result<Camera, String> {
    let projection = match c.projection.as_str() {
        "orthographic" => Projection::Orthographic {
            height: c
                .height
                .ok_or("camera.height: required for an orthographic camera")?,
        },
        "perspective" => Projection::Perspective {
            fov_y_deg: c
                .fov_y_deg
                .ok_or("camera.fov_y_deg: required for a perspective camera")?,
        },
        other => {
            return Err(format!(
                "camera.projection: must be \"orthographic\" or \"perspective\", got \"{other}\""
            ))
        }
    };
    let cam = Camera {
        eye: c.eye,
        target: c.target,
        up: c.up,
        projection,
    };
    cam.check().map_err(|(k, m)| format!("{k}: {m}"))?;
    Ok(cam)
}

fn transfer_of(t: &TransferMsg) -> Result<TransferFunction, String> {
    if t.points.len() > MAX_TRANSFER_POINTS {
        return Err(format!(
            "transfer: {} points, at most {MAX_TRANSFER_POINTS}",
            t.points.len()
        ));
    }
    crate::scene::transfer_from_rows(&t.points, t.unit_distance)
        .map_err(|(k, m)| format!("transfer.{k}: {m}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    const CAM: &str = r#""camera":{"eye":[0,0,10],"target":[0,0,0],"up":[0,1,0],"projection":"orthographic","height":5}"#;

    #[test]
    fn a_good_view_parses() {
        let m = parse(&format!(
            r#"{{"type":"view",{CAM},"interacting":true,"input":7}}"#
        ));
        match m.unwrap() {
            ClientMessage::View {
                camera: Some(c),
                interacting: true,
                input: 7,
                ..
            } => assert_eq!(c.eye, [0.0, 0.0, 10.0]),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_messages_are_refused_with_a_reason() {
        let cases = [
            ("not json", "malformed"),
            (r#"{"type":"launch"}"#, "malformed"),
            (
                r#"{"type":"view","camera":{"eye":[0,0,0],"target":[0,0,0],"up":[0,1,0],"projection":"orthographic","height":5}}"#,
                "camera",
            ),
            (
                r#"{"type":"view","transfer":{"unit_distance":1,"points":[[0.5,0,0,0,0],[0.2,1,1,1,1]]}}"#,
                "transfer",
            ),
            (r#"{"type":"options","ert":1.5}"#, "ERT"),
            (
                r#"{"type":"options","renderer":"magic"}"#,
                "unknown renderer",
            ),
            (r#"{"type":"data","field":""}"#, "field"),
            (r#"{"type":"data","step":-1}"#, "malformed"),
            (r#"{"type":"movie","action":"rewind"}"#, "movie.action"),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err();
            assert!(e.contains(want), "{text}: {e}");
        }
        // serde_json reads no NaN literal; a NaN is refused as malformed.
        assert!(parse(r#"{"type":"view","camera":{"eye":[NaN,0,0]}}"#).is_err());
        let big = format!(
            r#"{{"type":"view","pad":"{}"}}"#,
            "x".repeat(MAX_MESSAGE_BYTES)
        );
        assert!(parse(&big).unwrap_err().contains("exceeds"));
    }

    #[test]
    fn fields_and_steps_are_checked_against_the_data() {
        let fields = ["speed".to_string(), "pressure".to_string()];
        let m = parse(r#"{"type":"data","field":"pressure","step":1}"#).unwrap();
        assert!(check_data(&m, &fields, 2).is_ok());
        let e = check_data(&m, &fields, 1).unwrap_err();
        assert!(e.contains("time step 1 does not exist"), "{e}");
        let m = parse(r#"{"type":"data","field":"temperature"}"#).unwrap();
        let e = check_data(&m, &fields, 2).unwrap_err();
        assert!(e.contains("unknown field \"temperature\""), "{e}");
        assert!(e.contains("\"speed\", \"pressure\""), "{e}");
    }
}
