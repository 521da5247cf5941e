//! The files a series writes besides the last frame's report, for every
//! frontend alike (the command line prints the lines these return; the
//! Python module does not): every frame's image (`-o out-%04d.png`), the
//! per-frame CSV (`--series-csv`) and the movie (`--movie`, with ffmpeg).

use std::path::Path;

use anyhow::Context;

use crate::cluster::ClusterReport;
use crate::image::Image;
use crate::job::series::args::{frame_path, SeriesArgs};

/// Writes frame `k` of `n` to `output` as the frame completes, when
/// `output` has a `%d` pattern (every frame is then a file of its own);
/// returns what it did (the first and the last frame's line). `None`
/// without a pattern: [`write_series_images`] writes the last frame.
pub fn write_frame(
    output: &Path,
    k: usize,
    n: usize,
    image: &Image,
) -> anyhow::Result<Option<String>> {
    let Some(p) = frame_path(output, k) else {
        return Ok(None);
    };
    image.save_png(&p)?;
    Ok((k == 0 || k + 1 == n).then(|| format!("wrote {}", p.display())))
}

/// Writes the frames' images to `output` when given (every frame when it
/// has a `%d` pattern, else the last one; `written`: the pattern's frames
/// were written as they completed, [`write_frame`]) and `--movie`;
/// returns what it did, one line each.
pub fn write_series_images(
    output: Option<&Path>,
    s: &SeriesArgs,
    images: &[&Image],
    written: bool,
) -> anyhow::Result<Vec<String>> {
    let mut said = Vec::new();
    match output {
        Some(o) if written && frame_path(o, 0).is_some() && images.len() > 2 => {
            said.push(format!("({} frames written)", images.len()));
        }
        Some(o) if written && frame_path(o, 0).is_some() => {}
        Some(o) => write_frames(o, images, &mut said)?,
        None => {}
    }
    if let Some(m) = &s.movie {
        make_movie(s, m, images)?;
        said.push(format!("wrote {}", m.display()));
    }
    Ok(said)
}

/// Writes `--series-csv` from the last frame's report's series section
/// (nothing without either); returns what it did.
pub fn write_series_csv(s: &SeriesArgs, last: &ClusterReport) -> anyhow::Result<Option<String>> {
    let (Some(p), Some(series)) = (&s.series_csv, &last.series) else {
        return Ok(None);
    };
    std::fs::write(p, series.csv()).with_context(|| format!("cannot write {}", p.display()))?;
    Ok(Some(format!("wrote {}", p.display())))
}

fn write_frames(output: &Path, images: &[&Image], said: &mut Vec<String>) -> anyhow::Result<()> {
    let n = images.len();
    if frame_path(output, 0).is_some() {
        for (k, img) in images.iter().enumerate() {
            let p = frame_path(output, k).expect("a pattern");
            img.save_png(&p)?;
            if k == 0 || k + 1 == n {
                said.push(format!("wrote {}", p.display()));
            }
        }
        if n > 2 {
            said.push(format!("({n} frames written)"));
        }
        return Ok(());
    }
    let last = images.last().expect("at least one frame");
    last.save_png(output)?;
    said.push(if n > 1 {
        format!(
            "wrote {} (the last of {n} frames; -o out-%04d.png writes every frame)",
            output.display()
        )
    } else {
        format!("wrote {}", output.display())
    });
    Ok(())
}

/// Makes the movie with ffmpeg from the frames (written to a private
/// folder first, removed on every path).
fn make_movie(s: &SeriesArgs, movie: &Path, images: &[&Image]) -> anyhow::Result<()> {
    make_movie_of(movie, s.movie_fps.unwrap_or(10), images.len(), |k, p| {
        images[k].save_png(p).map_err(Into::into)
    })
}

/// Makes the movie `movie` (`.mp4` or `.gif`) at `fps` frames a second
/// with ffmpeg from `n` frames, frame `k` written as a PNG to the path
/// given by `write(k, path)` in a private folder (removed on every path):
/// the one movie writer of every frontend (`--movie`, the viewer's
/// recorded movies).
pub fn make_movie_of(
    movie: &Path,
    fps: u32,
    n: usize,
    mut write: impl FnMut(usize, &Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    struct Frames(std::path::PathBuf);
    impl Drop for Frames {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let dir =
        Frames(std::env::temp_dir().join(format!("pvrsim-movie-{}-{nanos}", std::process::id())));
    std::fs::create_dir(&dir.0)
        .with_context(|| format!("cannot make {} for the movie's frames", dir.0.display()))?;
    for k in 0..n {
        write(k, &dir.0.join(format!("f{k:06}.png")))?;
    }
    let fps = fps.to_string();
    let mut cmd = std::process::Command::new("ffmpeg");
    cmd.args(["-loglevel", "error", "-y", "-framerate", &fps, "-i"])
        .arg(dir.0.join("f%06d.png"));
    if movie
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mp4"))
    {
        // H.264 needs even sizes and a planar 4:2:0 format to play anywhere.
        cmd.args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-pix_fmt",
            "yuv420p",
        ]);
    }
    let st = cmd
        .arg(movie)
        .status()
        .with_context(|| format!("cannot run ffmpeg to make {}", movie.display()))?;
    anyhow::ensure!(
        st.success(),
        "ffmpeg failed making {} ({st})",
        movie.display()
    );
    Ok(())
}
