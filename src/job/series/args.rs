//! The options of a frame series (`pvrsim cluster --frames N --turn DEG`),
//! one set for mesh and grid scenes ([`SeriesArgs`]), and the cameras they
//! ask for ([`SeriesArgs::cameras`]).

use std::path::PathBuf;

use clap::Args;

use crate::cluster::series::Coherence;
use crate::scene::Camera;

/// Most frames in one run.
pub const MAX_FRAMES: u32 = 100_000;

/// Options of a frame series.
#[derive(Debug, Clone, Default, Args)]
pub struct SeriesArgs {
    /// Render N frames on the same nodes, the eye turning `--turn` degrees
    /// about the target (around the camera's up vector, right-handed)
    /// between frames. The nodes keep their data across frames (mesh
    /// scenes: every node's cells and vertices; grid scenes: the bricks'
    /// textures; worker processes receive the data once). With `-o` holding
    /// a `%d` pattern (e.g. `-o out-%04d.png`) every frame is written,
    /// otherwise the last; `--report` adds a `series` section (frames per
    /// second, per-frame times and bytes).
    #[arg(long, value_name = "N", conflicts_with = "series")]
    pub frames: Option<u32>,
    /// With --frames: degrees the eye turns about the target from one frame
    /// to the next (default 0).
    #[arg(long, value_name = "DEG", conflicts_with = "series")]
    pub turn: Option<f64>,
    /// Mesh scenes: replay a session from a series file, one `[[frame]]`
    /// per frame, each changing the camera (`eye`, `target`, `up`, `turn`),
    /// the transfer function (`transfer`), the field (`field`) or the time
    /// step (`mesh`: a mesh of the same topology) and keeping the rest
    /// (format: docs/experiments/interactive.md, `src/scene/series.rs`).
    /// Checked whole, time steps loaded, before the first frame runs.
    #[arg(long, value_name = "FILE.toml")]
    pub series: Option<PathBuf>,
    /// Mesh series in this process (virtual clock, threads): `placement`
    /// starts each frame with every cell on the node that processed it in
    /// the frame before (DLB's moves kept; same images: bit for bit with
    /// --canonical and ERT off), `off` starts every frame from the initial
    /// placement. Default: `placement` with partitioned data (cells move
    /// with their vertices: 36-frame aorta orbit, 8 nodes, 1.07x the
    /// modelled fps), `off` with replicated data (where it measured 0.92x:
    /// docs/experiments/interactive.md). Worker transports keep the
    /// set-up's placement (`off`).
    #[arg(long, value_enum)]
    pub coherence: Option<Coherence>,
    /// With --frames: write one CSV row per frame here (frame, eye,
    /// frame_s, phase1_s, composite_s, bytes, cells_bytes,
    /// cells_skipped_ert, cells_moved, compress_s; times modelled on the
    /// virtual clock, measured on a real transport; compress_s, the
    /// slowest worker's codec encoding, on real transports only).
    #[arg(long, value_name = "FILE")]
    pub series_csv: Option<PathBuf>,
    /// With a series: make a movie of the frames (`.mp4` or animated
    /// `.gif`) with `ffmpeg`, which must be on PATH (checked before any
    /// frame runs; without it, write the frames with `-o out-%04d.png`
    /// and run `ffmpeg -framerate 10 -i out-%04d.png out.mp4` elsewhere).
    #[arg(long, value_name = "FILE.mp4|FILE.gif")]
    pub movie: Option<PathBuf>,
    /// Frames per second of `--movie` (default 10).
    #[arg(long, value_name = "FPS", requires = "movie")]
    pub movie_fps: Option<u32>,
    /// Continue a stopped series: with `-o out-%04d.png`, the frames whose
    /// files exist (from frame 0 on, without a gap) are not rendered again;
    /// the series runs from the first missing one. Each frame's file is
    /// written as the frame completes, so a series stopped by Ctrl-C or a
    /// failure keeps what it finished.
    #[arg(long)]
    pub resume: bool,
    /// With --frames: widen the view (orthographic height, perspective
    /// field of view) to the data's bounding sphere, so that no frame of
    /// the orbit crops it. Without it every frame uses the scene's camera
    /// turned (frame 0 equals a one-off render), and an orbit that would
    /// crop the data is warned about before the first frame.
    #[arg(long, requires = "frames")]
    pub fit_orbit: bool,
}

impl SeriesArgs {
    /// Frames of the orbit asked for (1 without `--frames`).
    pub fn frames(&self) -> u32 {
        self.frames.unwrap_or(1)
    }

    /// Whether a series (more than one frame, or a series file) is asked for.
    pub fn is_series(&self) -> bool {
        self.frames.is_some() || self.series.is_some()
    }

    /// Checks the options (before anything loads).
    pub fn check(&self) -> anyhow::Result<()> {
        let frames = self.frames();
        anyhow::ensure!(frames >= 1, "--frames must be at least 1");
        anyhow::ensure!(
            frames <= MAX_FRAMES,
            "--frames {frames}: at most {MAX_FRAMES} frames in one run"
        );
        if let Some(turn) = self.turn {
            anyhow::ensure!(
                turn.is_finite(),
                "--turn must be a finite angle in degrees, got {turn}"
            );
            anyhow::ensure!(
                self.frames.is_some(),
                "--turn turns the camera between frames; give --frames N with it"
            );
        }
        anyhow::ensure!(
            self.series_csv.is_none() || self.is_series(),
            "--series-csv writes one row per frame of a series; give --frames N (or --series FILE) with it"
        );
        if let Some(m) = &self.movie {
            anyhow::ensure!(
                self.is_series(),
                "--movie makes a movie of a series' frames; give --frames N (or --series FILE) with it"
            );
            let ext = m
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase);
            anyhow::ensure!(
                matches!(ext.as_deref(), Some("mp4" | "gif")),
                "--movie {}: the file must end in .mp4 or .gif",
                m.display()
            );
            anyhow::ensure!(
                ffmpeg_found(),
                "--movie {}: ffmpeg is not on PATH (this machine cannot make a movie); write \
                 the frames with -o out-%04d.png and run `ffmpeg -framerate 10 -i \
                 out-%04d.png {}` where ffmpeg is installed",
                m.display(),
                m.display()
            );
        }
        anyhow::ensure!(
            self.movie_fps.is_none_or(|f| (1..=240).contains(&f)),
            "--movie-fps must be between 1 and 240"
        );
        Ok(())
    }

    /// With `--resume`: the first frame of `output`'s pattern whose file
    /// does not exist (0 without `--resume`). An error without a `%d`
    /// pattern in `output` or without a series.
    pub fn resume_at(&self, output: &std::path::Path, frames: usize) -> anyhow::Result<usize> {
        if !self.resume {
            return Ok(0);
        }
        anyhow::ensure!(
            self.is_series(),
            "--resume continues a series; give --frames N (or --series FILE) with it"
        );
        anyhow::ensure!(
            frame_path(output, 0).is_some(),
            "--resume needs every frame in a file of its own: give -o with a frame number \
             pattern, e.g. -o orbit-%04d.png"
        );
        let done = (0..frames)
            .take_while(|&k| frame_path(output, k).is_some_and(|p| p.is_file()))
            .count();
        Ok(done)
    }

    /// The cameras of the series: `cam`, then `cam` turned by `--turn`
    /// degrees a frame ([`crate::scene::orbit`]).
    pub fn cameras(&self, cam: &Camera) -> anyhow::Result<Vec<Camera>> {
        self.check()?;
        Ok(crate::scene::orbit(
            cam,
            self.frames(),
            self.turn.unwrap_or(0.0),
        ))
    }
}

impl SeriesArgs {
    /// The cameras of the series for the data `points` in images of
    /// `width` x `height`: with `--fit-orbit` the scene's camera widened
    /// to the data's bounding sphere, then turned ([`Self::cameras`]);
    /// without it, an orbit that crops the data is warned about (which
    /// frames, and what to do) before the first frame.
    pub fn orbit_cameras(
        &self,
        cam: &Camera,
        width: u32,
        height: u32,
        points: &[[f64; 3]],
    ) -> anyhow::Result<Vec<Camera>> {
        use crate::scene::orbit::{cropping_frames, fit_orbit};
        let base = if self.fit_orbit {
            let fitted = fit_orbit(cam, width, height, points).ok_or_else(|| {
                anyhow::anyhow!(
                    "--fit-orbit: the eye is inside the data's bounding sphere, so no field of \
                     view holds the data from every side (move the eye away from the target)"
                )
            })?;
            if fitted != *cam {
                eprintln!(
                    "note: --fit-orbit: {} to hold the data's bounding sphere from every side",
                    extent_change(cam, &fitted)
                );
            }
            fitted
        } else {
            *cam
        };
        let cams = self.cameras(&base)?;
        if self.frames.is_some() && !self.fit_orbit {
            // A scene that crops its data from its own side was framed so
            // on purpose: only a crop the turning adds is news.
            let crop = cropping_frames(&cams, width, height, points);
            if let Some(&first) = crop.first().filter(|&&f| f > 0) {
                let turn = self.turn.unwrap_or(0.0);
                crate::job::output::warn(format!(
                    "the orbit crops the data in {} of {} frames (the first: frame {first}, turned \
                     {:.0} degrees): the scene's view holds the data from its own side only; \
                     --fit-orbit widens it to the data's bounding sphere (frames then differ \
                     from one-off renders of the scene)",
                    crop.len(),
                    cams.len(),
                    first as f64 * turn
                ));
            }
        }
        Ok(cams)
    }
}

/// What `--fit-orbit` changed, for the note.
fn extent_change(from: &Camera, to: &Camera) -> String {
    use crate::scene::Projection;
    match (from.projection, to.projection) {
        (Projection::Orthographic { height: a }, Projection::Orthographic { height: b }) => {
            format!("orthographic height {a:.4} -> {b:.4}")
        }
        (Projection::Perspective { fov_y_deg: a }, Projection::Perspective { fov_y_deg: b }) => {
            format!("field of view {a:.2} -> {b:.2} degrees")
        }
        _ => "view widened".to_string(),
    }
}

/// Whether `ffmpeg` is on PATH (it answers `-version`).
pub fn ffmpeg_found() -> bool {
    std::process::Command::new("ffmpeg")
        .arg("-version")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The path of frame `k` for an output path with a printf-style `%d`
/// (`%04d`, `%d`): `Some` with the number put in, `None` without one.
pub fn frame_path(pattern: &std::path::Path, k: usize) -> Option<PathBuf> {
    let s = pattern.to_str()?;
    let at = s.find('%')?;
    let rest = &s[at + 1..];
    let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
    let after = &rest[digits.len()..];
    let after = after.strip_prefix('d')?;
    let width: usize = if digits.is_empty() {
        0
    } else {
        digits.parse().ok()?
    };
    Some(PathBuf::from(format!("{}{k:0width$}{after}", &s[..at])))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn frame_paths_fill_the_pattern() {
        assert_eq!(
            frame_path(Path::new("out-%04d.png"), 7),
            Some(PathBuf::from("out-0007.png"))
        );
        assert_eq!(
            frame_path(Path::new("dir/f%d.png"), 12),
            Some(PathBuf::from("dir/f12.png"))
        );
        assert_eq!(frame_path(Path::new("out.png"), 3), None);
        assert_eq!(frame_path(Path::new("out-%s.png"), 3), None);
    }

    #[test]
    fn series_options_are_checked() {
        let mut s = SeriesArgs::default();
        assert!(s.check().is_ok());
        s.turn = Some(10.0);
        assert!(s.check().unwrap_err().to_string().contains("--frames"));
        s.frames = Some(0);
        assert!(s.check().unwrap_err().to_string().contains("at least 1"));
        s.frames = Some(3);
        s.turn = Some(f64::NAN);
        assert!(s.check().unwrap_err().to_string().contains("finite"));
        s.turn = Some(90.0);
        let cam = crate::scene::Camera {
            eye: [0.0, 0.0, 5.0],
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            projection: crate::scene::Projection::Orthographic { height: 2.0 },
        };
        let c = s.cameras(&cam).unwrap();
        assert_eq!(c.len(), 3);
        // Right-handed about +y: +z turns to +x.
        assert!((c[1].eye[0] - 5.0).abs() < 1e-12 && c[1].eye[2].abs() < 1e-12);
    }
}
