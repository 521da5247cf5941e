use super::*;
use crate::scene::transfer::ControlPoint;

fn aorta_tf() -> TransferFunction {
    let pts = [
        [0.0000, 0.2300, 0.2990, 0.7540, 0.0000],
        [0.0400, 0.2815, 0.3616, 0.7927, 0.2094],
        [0.1000, 0.3588, 0.4554, 0.8508, 0.6979],
        [0.2400, 0.5391, 0.6744, 0.9863, 0.6979],
        [0.2500, 0.5520, 0.6900, 0.9960, 0.6595],
        [0.3400, 0.6647, 0.7530, 0.9488, 0.3141],
        [0.5000, 0.8650, 0.8650, 0.8650, 0.0838],
        [0.7500, 0.9580, 0.6040, 0.4820, 0.1256],
        [1.0000, 0.7060, 0.0160, 0.1500, 0.2443],
    ];
    TransferFunction::from_rows(&pts, 5.0)
}

/// Brute-force f64 integral: many small steps, each with the exact
/// constant-extinction formula at its midpoint, composited.
fn brute(tf: &TransferFunction, sa: f64, sb: f64, len: f64) -> (f64, [f64; 3]) {
    let n = 20_000;
    let (mut t, mut c) = (1.0f64, [0.0f64; 3]);
    for i in 0..n {
        let x = (i as f64 + 0.5) / n as f64;
        let s = sa + (sb - sa) * x;
        let (rgb, _) = tf.eval(s);
        let a = 1.0 - (-tf.extinction(s) * len / n as f64).exp();
        for k in 0..3 {
            c[k] += t * a * rgb[k];
        }
        t *= 1.0 - a;
    }
    (1.0 - t, c)
}

#[test]
fn exact_is_within_1e4_of_the_true_integral() {
    let tf = aorta_tf();
    let p = PreparedTf::new(&tf);
    let mut worst = 0.0f64;
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..3000 {
        let sa = rnd() * 1.1 - 0.05;
        let sb = if rnd() < 0.5 {
            sa + (rnd() - 0.5) * 0.1
        } else {
            rnd() * 1.1 - 0.05
        };
        let len = [0.01, 0.5, 2.0, 10.0, 40.0][(rnd() * 5.0) as usize % 5] * rnd();
        let got = p.exact(sa as f32, sb as f32, len as f32);
        let (a, c) = brute(&tf, sa, sb, len);
        let err = (got.a as f64 - a).abs().max(
            (0..3)
                .map(|k| (got.rgb[k] as f64 - c[k]).abs())
                .fold(0.0, f64::max),
        );
        worst = worst.max(err);
        assert!(
            err < 1e-4,
            "sa={sa} sb={sb} len={len}: got {got:?}, want a={a} c={c:?}, err {err}"
        );
    }
    eprintln!("worst exact error {worst:e}");
}

#[test]
fn opacity_one_and_zero_length_are_finite() {
    let tf = TransferFunction {
        points: vec![
            ControlPoint {
                s: 0.0,
                rgb: [1.0, 0.5, 0.0],
                opacity: 1.0,
            },
            ControlPoint {
                s: 1.0,
                rgb: [1.0, 0.5, 0.0],
                opacity: 1.0,
            },
        ],
        unit_distance: 1.0,
    };
    let p = PreparedTf::new(&tf);
    for integ in [Integrator::Exact, Integrator::Midpoint] {
        let r = p.integrate(integ, 0.2, 0.8, 3.0);
        assert!(
            r.a > 0.999_999 && r.a <= 1.0 && r.rgb.iter().all(|v| v.is_finite()),
            "{r:?}"
        );
        let z = p.integrate(integ, 0.2, 0.8, 0.0);
        assert_eq!(z.a, 0.0);
    }
}

/// The definition: zero opacity at both ends and at every control point
/// between them (the opacity is linear in between).
fn transparent_by_definition(p: &PreparedTf, lo: f32, hi: f32) -> bool {
    if p.eval(lo).0 > 0.0 || p.eval(hi).0 > 0.0 {
        return false;
    }
    let (i0, i1) = (p.piece_index(lo), p.piece_index(hi));
    (i0..i1).all(|b| p.pieces[b + 1].o0 <= 0.0)
}

proptest::proptest! {
    #[test]
    fn zero_runs_agree_with_the_definition(
        ops in proptest::collection::vec(0u8..4, 2..9),
        cuts in proptest::collection::vec(0.0f64..1.0, 2..9),
        queries in proptest::collection::vec((-0.2f32..1.2, 0.0f32..0.5), 1..60),
    ) {
        // Control points at sorted positions (duplicates allowed), with
        // opacity 0 half of the time so zero runs of every shape occur.
        let n = ops.len().min(cuts.len());
        let mut s: Vec<f64> = cuts[..n].to_vec();
        s.sort_by(|a, b| a.total_cmp(b));
        let points = (0..n)
            .map(|i| ControlPoint {
                s: s[i],
                rgb: [0.5, 0.5, 0.5],
                opacity: [0.0, 0.0, 0.3, 1.0][ops[i] as usize],
            })
            .collect();
        let p = PreparedTf::new(&TransferFunction { points, unit_distance: 1.0 });
        // Also ask about the control points themselves.
        let mut qs = queries.clone();
        qs.extend(s.iter().map(|&v| (v as f32, 0.0)));
        for (lo, w) in qs {
            let hi = lo + w;
            proptest::prop_assert_eq!(
                p.is_transparent(lo, hi),
                transparent_by_definition(&p, lo, hi),
                "[{}, {}] with {:?}", lo, hi, p.zero_runs
            );
        }
    }
}

#[test]
fn transparent_intervals() {
    let p = PreparedTf::new(&aorta_tf());
    assert!(p.is_transparent(-1.0, 0.0));
    assert!(!p.is_transparent(-1.0, 0.01));
    assert!(!p.is_transparent(0.3, 0.31));
}

/// A TF with more control points than the counted pass 1 takes (LUT path).
fn many_point_tf() -> TransferFunction {
    let pts: Vec<[f64; 5]> = (0..40)
        .map(|i| {
            let s = i as f64 / 39.0;
            [s, s, 1.0 - s, 0.5, 0.5 + 0.45 * (i as f64 * 1.7).sin()]
        })
        .collect();
    TransferFunction::from_rows(&pts, 5.0)
}

/// The batch (passes 1-3, vectorised) gives what the scalar integrators
/// give lane by lane, bit for bit: lanes in one piece, lanes crossing one
/// or several control points in either direction, lanes needing sub-steps,
/// with and without a piece hint, for the counted and the LUT pass 1.
#[test]
fn batch_matches_scalar_bit_for_bit() {
    for tf in [aorta_tf(), many_point_tf()] {
        let p = PreparedTf::new(&tf);
        for integrator in [Integrator::Exact, Integrator::Midpoint] {
            let mut rng = 0x1234_5678u32;
            let mut next = || {
                rng ^= rng << 13;
                rng ^= rng >> 17;
                rng ^= rng << 5;
                rng as f32 / u32::MAX as f32
            };
            let mut b = Batch::default();
            for round in 0..40 {
                b.n = 1 + (round * 37) % BATCH;
                for l in 0..b.n {
                    let sa = next() * 1.1 - 0.05;
                    let sb = if l % 3 == 0 {
                        sa + 0.01 * next()
                    } else {
                        next()
                    };
                    b.s_in[l] = sa;
                    b.s_out[l] = sb;
                    b.len[l] = next() * if l % 5 == 0 { 20.0 } else { 2.0 };
                    let hint = p.single_piece(sa.min(sb), sa.max(sb));
                    b.piece_hint[l] = if l % 2 == 0 { hint } else { NO_PIECE };
                }
                p.integrate_batch(integrator, &mut b);
                for l in 0..b.n {
                    let want = p.integrate(integrator, b.s_in[l], b.s_out[l], b.len[l]);
                    let got = b.result(l);
                    let bits = |v: Rgba| [v.rgb[0], v.rgb[1], v.rgb[2], v.a].map(f32::to_bits);
                    assert_eq!(
                        bits(got),
                        bits(want),
                        "{integrator} lane {l}: {got:?} vs {want:?} (s {} -> {}, len {})",
                        b.s_in[l],
                        b.s_out[l],
                        b.len[l]
                    );
                }
            }
        }
    }
}

proptest::proptest! {
    /// `optical_depth_bound` bounds what both integrators make of any
    /// segment, one at a time and batched: `1 - alpha >= e^{-bound} (1 -
    /// 1e-5)` (the rounding `TerminationWatch::may_record` allows a
    /// segment) wherever the bound is below 1 (a larger one never lets a
    /// segment wait), and `1 - alpha >= e^{-bound} (1 - 1e-5) - 1.2e-7`
    /// (the rounding `watch::cannot_cross` allows) everywhere, on transfer
    /// functions with opacities up to 1 and lengths up to many unit
    /// distances.
    #[test]
    fn optical_depth_bound_holds(
        ops in proptest::collection::vec(proptest::sample::select(vec![0.0f64, 0.1, 0.5, 0.9, 0.999, 1.0]), 2..6),
        unit in proptest::sample::select(vec![0.5f64, 1.0, 5.0]),
        segs in proptest::collection::vec((0.0f32..1.0, 0.0f32..1.0, 0.0f32..20.0), 1..40),
    ) {
        let n = ops.len();
        let points = (0..n)
            .map(|i| ControlPoint {
                s: i as f64 / (n - 1) as f64,
                rgb: [0.5, 0.5, 0.5],
                opacity: ops[i],
            })
            .collect();
        let p = PreparedTf::new(&TransferFunction { points, unit_distance: unit });
        for integrator in [Integrator::Exact, Integrator::Midpoint] {
            let mut b = Batch::default();
            for (l, &(sa, sb, len)) in segs.iter().enumerate() {
                b.s_in[l] = sa;
                b.s_out[l] = sb;
                b.len[l] = len;
            }
            b.n = segs.len();
            p.integrate_batch(integrator, &mut b);
            for (l, &(sa, sb, len)) in segs.iter().enumerate() {
                let x = p.optical_depth_bound(len) as f64;
                let floor = (-x).exp() * (1.0 - 1e-5) - if x >= 1.0 { 1.2e-7 } else { 0.0 };
                for a in [p.integrate(integrator, sa, sb, len).a, b.result(l).a] {
                    proptest::prop_assert!(
                        (1.0 - a as f64) >= floor,
                        "{integrator:?} s {sa}..{sb} length {len}: 1 - alpha {} < {floor}", 1.0 - a
                    );
                }
            }
        }
    }
}
