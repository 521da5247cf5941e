//! How a frame drawn while the user interacts is drawn ([`Level`]: the
//! image reduction and whether the coarse mesh stands in for the data),
//! and `--interactive-scale auto`'s choice of it ([`Pace`]): the finest
//! level whose frame time (render + encode) holds [`AUTO_TARGET_S`],
//! from the times measured at each level during the last interactive
//! frames (a level not measured lately: estimated from the level of the same data
//! measured last, or tried). Cell projection's cost does not shrink with the pixels
//! (every cell is projected), so on a large mesh only the coarse mesh
//! holds the target; on a small one the full data at 1/2 does.

use super::InteractiveScale;

/// The frame-time target of `--interactive-scale auto`, seconds (render
/// and encode; the page's decode and the wait for the frame in flight
/// come on top of it in the input-to-frame latency).
pub const AUTO_TARGET_S: f64 = 0.04;

/// Interactive frames after which a level's measured time is forgotten
/// (load changes; a level once too slow is tried again).
const FRESH_FRAMES: u64 = 40;

/// How one frame is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Level {
    /// The image at `1/divisor` of the scene's size along each axis.
    pub divisor: u32,
    /// The coarse stand-in of the mesh instead of the data.
    pub coarse: bool,
}

impl Level {
    /// A full frame: the data at full resolution.
    pub const FULL: Level = Level {
        divisor: 1,
        coarse: false,
    };
}

/// The choice of interactive levels over a viewer's life.
pub struct Pace {
    scale: InteractiveScale,
    levels: Vec<Level>,
    /// Per level: the last measured seconds and the interactive frame
    /// number it was measured at.
    measured: Vec<Option<(f64, u64)>>,
    last_full_s: Option<f64>,
    frame: u64,
}

impl Pace {
    /// The levels `scale` may use (`coarse`: the backend has a coarse
    /// mesh).
    pub fn new(scale: InteractiveScale, coarse: bool) -> Pace {
        let levels: Vec<Level> = match scale {
            InteractiveScale::Auto => {
                let data = [2, 4].map(|divisor| Level {
                    divisor,
                    coarse: false,
                });
                if coarse {
                    let c = [2, 4, 8].map(|divisor| Level {
                        divisor,
                        coarse: true,
                    });
                    data.into_iter().chain(c).collect()
                } else {
                    data.into_iter()
                        .chain([Level {
                            divisor: 8,
                            coarse: false,
                        }])
                        .collect()
                }
            }
            fixed => vec![Level {
                divisor: fixed.divisor(),
                coarse: false,
            }],
        };
        Pace {
            scale,
            measured: vec![None; levels.len()],
            levels,
            last_full_s: None,
            frame: 0,
        }
    }

    /// The level of the next interactive frame.
    pub fn choose(&self) -> Level {
        if self.scale != InteractiveScale::Auto {
            return self.levels[0];
        }
        (0..self.levels.len())
            .find(|&i| self.estimate(i) <= AUTO_TARGET_S)
            .map_or(*self.levels.last().expect("levels"), |i| self.levels[i])
    }

    /// The estimated seconds of level `i`: measured lately, else scaled
    /// from a level of the same data measured lately (cost ~ pixels, an
    /// optimistic guess for cell projection), else from the last full
    /// frame for the data, else 0 (try it).
    fn estimate(&self, i: usize) -> f64 {
        let fresh = |k: usize| {
            self.measured[k]
                .filter(|&(_, at)| self.frame.saturating_sub(at) <= FRESH_FRAMES)
                .map(|(t, _)| t)
        };
        if let Some(t) = fresh(i) {
            return t;
        }
        let l = self.levels[i];
        let ratio = |d: u32| f64::from(d * d) / f64::from(l.divisor * l.divisor);
        // The same data's level measured last.
        if let Some((k, t)) = (0..self.levels.len())
            .filter(|&k| self.levels[k].coarse == l.coarse && fresh(k).is_some())
            .max_by_key(|&k| self.measured[k].map_or(0, |(_, at)| at))
            .and_then(|k| fresh(k).map(|t| (k, t)))
        {
            return t * ratio(self.levels[k].divisor);
        }
        match (l.coarse, self.last_full_s) {
            (false, Some(t)) => t * ratio(1),
            _ => 0.0,
        }
    }

    /// Records a frame's seconds (render and encode) at `level`.
    pub fn record(&mut self, level: Level, seconds: f64) {
        if level == Level::FULL {
            self.last_full_s = Some(seconds);
            return;
        }
        self.frame += 1;
        if let Some(i) = self.levels.iter().position(|&l| l == level) {
            self.measured[i] = Some((seconds, self.frame));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DATA2: Level = Level {
        divisor: 2,
        coarse: false,
    };

    fn level(divisor: u32, coarse: bool) -> Level {
        Level { divisor, coarse }
    }

    #[test]
    fn fixed_scales_never_change() {
        let mut p = Pace::new(InteractiveScale::Four, true);
        assert_eq!(p.choose(), level(4, false));
        p.record(level(4, false), 10.0);
        assert_eq!(p.choose(), level(4, false));
    }

    /// A large mesh: the data is too slow at every reduction, the coarse
    /// mesh holds the target at 1/2 once measured; a fast machine comes
    /// back to the data.
    #[test]
    fn auto_takes_the_finest_level_that_holds_the_target() {
        let mut p = Pace::new(InteractiveScale::Auto, true);
        assert_eq!(p.choose(), DATA2, "nothing measured: the finest");
        p.record(Level::FULL, 0.4);
        // 0.4 / 4 = 0.1 > target; 0.4 / 16 = 0.025: 1/4 of the data.
        assert_eq!(p.choose(), level(4, false));
        p.record(level(4, false), 0.15);
        // The data measured too slow at 1/4 (so at 1/2 too): the coarse
        // mesh, tried at its finest.
        assert_eq!(p.choose(), level(2, true));
        p.record(level(2, true), 0.06);
        assert_eq!(p.choose(), level(4, true));
        p.record(level(4, true), 0.02);
        assert_eq!(p.choose(), level(4, true), "1/2 measured too slow lately");
        for _ in 0..=FRESH_FRAMES {
            p.record(level(4, true), 0.02);
        }
        // The old measurements are forgotten: the data is tried again.
        p.record(Level::FULL, 0.1);
        assert_eq!(p.choose(), DATA2);
        p.record(DATA2, 0.03);
        assert_eq!(p.choose(), DATA2);
    }

    #[test]
    fn without_a_coarse_mesh_auto_reduces_down_to_an_eighth() {
        let mut p = Pace::new(InteractiveScale::Auto, false);
        p.record(level(2, false), 1.0);
        p.record(level(4, false), 1.0);
        p.record(level(8, false), 1.0);
        assert_eq!(p.choose(), level(8, false));
    }
}
