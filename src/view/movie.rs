//! Recording a movie of what the page shows: while recording, the server
//! keeps every full-resolution frame it sends (the lossless PNG of the
//! frame message, the pixels `pvrsim render` writes), bounded by
//! [`MAX_MOVIE_FRAMES`] and [`MAX_MOVIE_BYTES`] (past either it keeps no
//! more and says so once); on stop it writes the movie with the series'
//! one movie writer ([`crate::job::series::output::make_movie_of`],
//! ffmpeg) and serves it at `GET /movie.mp4`.

use std::sync::Arc;

use anyhow::Context;

/// The most frames a recorded movie keeps.
pub const MAX_MOVIE_FRAMES: usize = 600;

/// The most bytes of PNG frames a recording keeps.
pub const MAX_MOVIE_BYTES: usize = 256 << 20;

/// Frames per second of a recorded movie (the `--movie-fps` default).
pub const MOVIE_FPS: u32 = 10;

/// The movie recorder's state.
#[derive(Default)]
pub struct Recorder {
    recording: bool,
    frames: Vec<Arc<Vec<u8>>>,
    bytes: usize,
    full: bool,
    /// The last movie written (`GET /movie.mp4`).
    pub movie: Option<Arc<Vec<u8>>>,
}

impl Recorder {
    /// Starts a recording whose first frame is `current` (the full frame
    /// on the page now, if any); refused while one runs.
    pub fn start(&mut self, current: Option<Arc<Vec<u8>>>) -> Result<(), String> {
        if self.recording {
            return Err("a movie is being recorded already: stop it first".into());
        }
        *self = Recorder {
            recording: true,
            movie: self.movie.take(),
            ..Recorder::default()
        };
        if let Some(f) = current {
            self.add(f);
        }
        Ok(())
    }

    /// Whether a recording runs.
    pub fn recording(&self) -> bool {
        self.recording
    }

    /// Keeps a full frame's PNG while recording; the first refusal past
    /// the limits is returned (for the page), later ones are silent.
    pub fn add(&mut self, png: Arc<Vec<u8>>) -> Option<String> {
        if !self.recording {
            return None;
        }
        if self.frames.len() >= MAX_MOVIE_FRAMES || self.bytes + png.len() > MAX_MOVIE_BYTES {
            if self.full {
                return None;
            }
            self.full = true;
            return Some(format!(
                "movie: the recording holds its limit ({} frames, {} MiB of at most \
                 {MAX_MOVIE_FRAMES} frames or {} MiB); later frames are not kept: stop to \
                 write the movie",
                self.frames.len(),
                self.bytes >> 20,
                MAX_MOVIE_BYTES >> 20
            ));
        }
        self.bytes += png.len();
        self.frames.push(png);
        None
    }

    /// The number of frames kept so far.
    pub fn frames(&self) -> usize {
        self.frames.len()
    }

    /// Ends the recording: its frames (refused when none runs or none was
    /// kept).
    pub fn stop(&mut self) -> Result<Vec<Arc<Vec<u8>>>, String> {
        if !self.recording {
            return Err("no movie is being recorded".into());
        }
        self.recording = false;
        let frames = std::mem::take(&mut self.frames);
        self.bytes = 0;
        if frames.is_empty() {
            return Err("movie: no full-resolution frame was shown while recording".into());
        }
        Ok(frames)
    }
}

/// Writes the MP4 of `frames` (PNG files) at [`MOVIE_FPS`] with the
/// series' movie writer; its bytes.
pub fn write(frames: &[Arc<Vec<u8>>]) -> anyhow::Result<Vec<u8>> {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let movie =
        std::env::temp_dir().join(format!("pvrsim-view-{}-{nanos}.mp4", std::process::id()));
    let made =
        crate::job::series::output::make_movie_of(&movie, MOVIE_FPS, frames.len(), |k, p| {
            std::fs::write(p, frames[k].as_slice())
                .with_context(|| format!("cannot write {}", p.display()))
        });
    let bytes = made.and_then(|()| {
        std::fs::read(&movie).with_context(|| format!("cannot read {}", movie.display()))
    });
    let _ = std::fs::remove_file(&movie);
    let bytes = bytes?;
    anyhow::ensure!(!bytes.is_empty(), "ffmpeg wrote an empty movie");
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_recorder_keeps_frames_up_to_its_limit_and_says_so_once() {
        let mut r = Recorder::default();
        assert!(r.add(Arc::new(vec![1])).is_none());
        assert!(r.stop().is_err(), "not recording");
        r.start(Some(Arc::new(vec![0; 10]))).unwrap();
        assert!(r.start(None).is_err(), "already recording");
        for _ in 1..MAX_MOVIE_FRAMES {
            assert!(r.add(Arc::new(vec![0; 10])).is_none());
        }
        assert_eq!(r.frames(), MAX_MOVIE_FRAMES);
        let e = r
            .add(Arc::new(vec![0; 10]))
            .expect("a refusal past the limit");
        assert!(e.contains("limit"), "{e}");
        assert!(r.add(Arc::new(vec![0; 10])).is_none(), "said once");
        assert_eq!(r.stop().unwrap().len(), MAX_MOVIE_FRAMES);
        r.start(None).unwrap();
        assert!(r.add(Arc::new(vec![0; MAX_MOVIE_BYTES + 1])).is_some());
        assert!(r.stop().unwrap_err().contains("no full-resolution frame"));
    }
}
