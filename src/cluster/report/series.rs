//! The series section of a report ([`SeriesReport`]: `series.fps`,
//! `series.frames[i].frame_s`, `series.frames[i].bytes`), built by
//! [`crate::cluster::series::report`].

use serde::Serialize;

use crate::cluster::ClockKind;

/// What a series carries from one frame to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Coherence {
    /// Every frame starts from the initial placement.
    Off,
    /// Each frame starts from where the last one's cells ended: a cell
    /// that DLB moved stays on the node that processed it (culled cells
    /// stay where they were). The frame computes the same image (bit for
    /// bit with `--canonical` and ERT off; with ERT, within its bound).
    Placement,
}

/// One frame's row of a series.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SeriesFrame {
    /// Frame index, from 0.
    pub frame: usize,
    /// The frame's data state (time step) of the series, from 0.
    pub data: usize,
    /// The eye of the frame's camera.
    pub eye: [f64; 3],
    /// Seconds of the frame: modelled on the virtual clock, measured on
    /// the wall clock (a real transport: from its set-up to the image).
    pub frame_s: f64,
    /// Phase-1 seconds (same clock).
    pub phase1_s: f64,
    /// Compositing seconds (same clock).
    pub composite_s: f64,
    /// Of phase 2, the seconds the slowest worker spent encoding
    /// (compressing) its messages with the codec, measured on a real
    /// transport (IceT's compress time); `null` in this process.
    pub compress_s: Option<f64>,
    /// Bytes of the frame: payload of every message of both phases (the
    /// report's `bytes_total`: modelled on the virtual clock, counted by the
    /// channels with threads); over worker processes or TCP, every byte
    /// measured on the wire (set-up and cells included).
    pub bytes: u64,
    /// Of `bytes`, the cells sent to workers at set-up (0 when the workers
    /// kept them from an earlier frame; always 0 in this process).
    pub cells_bytes: u64,
    /// Cells skipped by ERT on all nodes.
    pub cells_skipped_ert: u64,
    /// Cells moved by DLB.
    pub cells_moved: u64,
    /// Workers lost in this frame and what was done (`--on-failure
    /// reassign`: the frame ran again on the survivors, who serve the
    /// frames after it): the frame's `transport.reassigned` (or
    /// `pieces.reassigned`). Absent when no worker was lost.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reassigned: Option<super::transport::Reassigned>,
}

/// The series section of a report (`series.fps`, `series.frames[i]...`).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SeriesReport {
    /// Frames rendered.
    pub n_frames: usize,
    /// What each frame carried over from the one before (`--coherence`;
    /// worker transports: `off`, their cells stay where the set-up put them).
    pub coherence: Coherence,
    /// The clock of the times: `virtual` (modelled) or `wall` (measured).
    pub clock: ClockKind,
    /// Frames per second over the whole series: `n_frames / total_s`.
    pub fps: f64,
    /// Frames per second after the first frame (which pays the set-up on a
    /// real transport); `null` with one frame.
    pub fps_after_first: Option<f64>,
    /// Sum of the frames' seconds.
    pub total_s: f64,
    /// Per frame, in order.
    pub frames: Vec<SeriesFrame>,
}

impl SeriesReport {
    /// The per-frame rows as CSV (a header line, then one line a frame).
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "frame,data,eye_x,eye_y,eye_z,frame_s,phase1_s,composite_s,bytes,cells_bytes,cells_skipped_ert,cells_moved,compress_s\n",
        );
        for f in &self.frames {
            s.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                f.frame,
                f.data,
                f.eye[0],
                f.eye[1],
                f.eye[2],
                f.frame_s,
                f.phase1_s,
                f.composite_s,
                f.bytes,
                f.cells_bytes,
                f.cells_skipped_ert,
                f.cells_moved,
                f.compress_s.map(|c| c.to_string()).unwrap_or_default()
            ));
        }
        s
    }

    /// One line for the terminal.
    pub fn line(&self) -> String {
        let kind = match self.clock {
            ClockKind::Virtual => "modelled",
            ClockKind::Wall => "measured",
        };
        let after = self
            .fps_after_first
            .map(|f| format!(", {f:.2} after the first"))
            .unwrap_or_default();
        format!(
            "series: {} frames in {:.4} s ({kind}): {:.2} frames/s{after}",
            self.n_frames, self.total_s, self.fps
        )
    }
}
