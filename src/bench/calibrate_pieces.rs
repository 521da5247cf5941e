//! `pvrsim calibrate`: the exact integrator's price of a segment that
//! crosses a transfer-function control point, measured directly.
//!
//! The step fit cannot see it: its samples are single scan calls whose
//! piece counts follow their pixel counts, and the non-negative fit gives
//! the column 0. Yet two halves of the small aorta with the same cells,
//! pixels and segments differ by 30 % in scan time, and by 4 % with the
//! midpoint integrator: the difference is the segments that cross control
//! points. So: a batch of segments that stay inside one piece and a batch
//! of the same lanes that each cross one point (two pieces) are integrated
//! many times with the scene's transfer function; the extra time over the
//! extra pieces is `per_segment_piece`. The step fit then fits what is left
//! after that term ([`crate::node::calibration::fit_profile`]).

use super::timer::{Timer, Watch};
use crate::render::cell::integrate::{Batch, BATCH, NO_PIECE};
use crate::render::cell::{Integrator, PreparedTf};
use crate::scene::TransferFunction;

/// Seconds per piece integrated of a crossing segment (0 when the transfer
/// function has fewer than two pieces of positive width).
pub fn measure(tf: &TransferFunction, repeats: usize, timer: Timer) -> f64 {
    let s: Vec<f64> = tf.points.iter().map(|p| p.s).collect();
    // Pieces of positive width, as (start, width).
    let pieces: Vec<(f64, f64)> = s
        .windows(2)
        .filter(|w| w[1] - w[0] > 1e-4)
        .map(|w| (w[0], w[1] - w[0]))
        .collect();
    // Pairs of adjacent pieces (a crossing of the point between them).
    let pairs: Vec<usize> = (0..pieces.len().saturating_sub(1))
        .filter(|&j| (pieces[j].0 + pieces[j].1 - pieces[j + 1].0).abs() < 1e-9)
        .collect();
    if pairs.is_empty() {
        return 0.0;
    }
    let prepared = PreparedTf::new(tf);
    let len = (0.3 * tf.unit_distance) as f32;
    let batch = |cross: bool| {
        let mut b = Batch::default();
        for l in 0..BATCH {
            let j = pairs[l % pairs.len()];
            let (a, w) = pieces[j];
            if cross {
                let (a2, w2) = pieces[j + 1];
                b.s_in[l] = (a + 0.5 * w) as f32;
                b.s_out[l] = (a2 + 0.5 * w2) as f32;
            } else {
                b.s_in[l] = (a + 0.3 * w) as f32;
                b.s_out[l] = (a + 0.7 * w) as f32;
            }
            b.len[l] = len;
            b.piece_hint[l] = NO_PIECE;
        }
        b.n = BATCH;
        b
    };
    let (mut inside, mut crossing) = (batch(false), batch(true));
    let reps = 2000;
    let time = |b: &mut Batch| {
        let t = Watch::start(timer);
        for _ in 0..reps {
            prepared.integrate_batch(Integrator::Exact, std::hint::black_box(&mut *b));
        }
        t.secs()
    };
    let (mut t_in, mut t_cross) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..repeats.max(1) {
        t_in = t_in.min(time(&mut inside));
        t_cross = t_cross.min(time(&mut crossing));
    }
    let extra = (crossing.pieces as f64 - inside.pieces as f64) * reps as f64;
    if extra <= 0.0 {
        return 0.0;
    }
    ((t_cross - t_in) / extra).max(0.0)
}
