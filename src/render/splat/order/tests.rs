//! Property tests of the orderings: permutations, face-neighbour back-to-front
//! order (orthographic and perspective), the DDA's view-aligned bound and the
//! sorts' depth order.

use proptest::prelude::*;

use super::*;

fn dims_strategy() -> impl Strategy<Value = [u64; 3]> {
    [1u64..9, 1u64..9, 1u64..9]
}

/// Random directions plus the degenerate ones: axis-aligned, exactly 45° in
/// a coordinate plane, the body diagonal, and a 45° pair with a small third.
fn dir_strategy() -> impl Strategy<Value = [f64; 3]> {
    let sign = prop_oneof![Just(1.0f64), Just(-1.0f64)];
    prop_oneof![
        [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0]
            .prop_filter("non-zero", |d| d.iter().any(|x| x.abs() > 1e-3)),
        (0usize..3, sign.clone()).prop_map(|(a, s)| {
            let mut d = [0.0; 3];
            d[a] = s;
            d
        }),
        (0usize..3, sign.clone(), sign.clone()).prop_map(|(a, s, t)| {
            let mut d = [0.0; 3];
            d[a] = s;
            d[(a + 1) % 3] = t;
            d
        }),
        (sign.clone(), sign.clone(), sign.clone()).prop_map(|(a, b, c)| [a, b, c]),
        (0usize..3, sign.clone(), sign, 1e-9f64..0.2).prop_map(|(a, s, t, e)| {
            let mut d = [e; 3];
            d[a] = s;
            d[(a + 1) % 3] = t;
            d
        }),
    ]
}

fn spacing_strategy() -> impl Strategy<Value = [f64; 3]> {
    prop_oneof![Just([1.0; 3]), [0.5f64..2.0, 0.5f64..2.0, 0.5f64..2.0]]
}

/// An eye in grid coordinates, inside or outside the grid, kept 1e-6 away
/// from voxel face planes (half-integers), where two neighbours are
/// equidistant and neither hides the other.
fn eye_strategy() -> impl Strategy<Value = [f64; 3]> {
    [-6.0f64..14.0, -6.0f64..14.0, -6.0f64..14.0].prop_map(|e| {
        e.map(|x| {
            let f = x - x.floor();
            if (f - 0.5).abs() < 1e-6 {
                x + 1e-3
            } else {
                x
            }
        })
    })
}

/// Position of every voxel in `order`; checks it is a permutation.
fn positions(order: &[u64], n: u64) -> Vec<usize> {
    assert_eq!(order.len() as u64, n, "every voxel exactly once");
    let mut pos = vec![usize::MAX; n as usize];
    for (p, &i) in order.iter().enumerate() {
        assert_eq!(pos[i as usize], usize::MAX, "voxel {i} visited twice");
        pos[i as usize] = p;
    }
    pos
}

/// Checks that each voxel comes after its farther face neighbours;
/// `farther(v, a)`: `Some(true)` if `v + e_a` is farther than `v`,
/// `Some(false)` if nearer, `None` if neither.
fn check_faces(
    order: &[u64],
    dims: [u64; 3],
    farther: impl Fn([u64; 3], usize) -> Option<bool>,
) -> Result<(), TestCaseError> {
    let n = dims.iter().product();
    let pos = positions(order, n);
    let st = strides(dims);
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let v = [i, j, k];
                let idx = (i + dims[0] * (j + dims[1] * k)) as usize;
                for a in 0..3 {
                    if v[a] + 1 >= dims[a] {
                        continue;
                    }
                    let nb = idx + st[a] as usize;
                    match farther(v, a) {
                        Some(true) => prop_assert!(
                            pos[nb] < pos[idx],
                            "{v:?}: its farther neighbour along {a} comes later"
                        ),
                        Some(false) => prop_assert!(
                            pos[idx] < pos[nb],
                            "{v:?} comes after its nearer neighbour along {a}"
                        ),
                        None => {}
                    }
                }
            }
        }
    }
    Ok(())
}

/// A pseudo-random kept set of density about `density` (hash of the index).
fn kept_set(seed: u64, density: f64) -> impl Fn(u64) -> bool + Sync {
    move |i: u64| {
        let h = (i ^ seed).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        ((h >> 11) as f64 / (1u64 << 53) as f64) < density
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// The pre-pass walks (line masks, sparse axis and DDA) emit exactly the
    /// full walk's sequence filtered by `keep`, orthographic and perspective,
    /// including lines longer than one mask word.
    #[test]
    fn sparse_walks_equal_the_filtered_full_walks(
        dims in prop_oneof![dims_strategy(), [1u64..70, 1u64..5, 1u64..70]],
        d in dir_strategy(), sp in spacing_strategy(), eye in eye_strategy(),
        persp in any::<bool>(), seed in any::<u64>(), density in prop_oneof![Just(0.0), Just(1.0), 0.0f64..1.0]
    ) {
        let view = if persp {
            OrderView::Perspective { eye, spacing: sp }
        } else {
            OrderView::orthographic(d, sp)
        };
        let keep = kept_set(seed, density);
        let mut scratch = sort::SortScratch::default();
        for order in [Order::Axis, Order::Dda] {
            let mut full = Vec::new();
            visit_kept(order, dims, &view, &keep, |i| full.push(i));
            // Payload: the index times 3, to check it travels with the index.
            let class = |i: u64| keep(i).then_some(3 * i);
            let mut fast = vec![(7u64, 0u64); 3];
            let built = collect_kept(order, dims, &view, &keep, &class, &mut scratch, &mut fast);
            prop_assert!(built >= 1);
            let idx: Vec<u64> = fast.iter().map(|x| x.0).collect();
            prop_assert_eq!(&idx, &full, "{}", order);
            prop_assert!(fast.iter().all(|&(i, t)| t == 3 * i), "{}: payloads", order);
        }
    }

    #[test]
    fn orthographic_orders_are_back_to_front(
        dims in dims_strategy(), d in dir_strategy(), sp in spacing_strategy()
    ) {
        let view = OrderView::orthographic(d, sp);
        let OrderView::Orthographic { w } = view else { unreachable!() };
        for order in Order::ALL {
            let o = collect(order, dims, &view);
            check_faces(&o, dims, |_, a| {
                if w[a] > 0.0 { Some(true) } else if w[a] < 0.0 { Some(false) } else { None }
            }).map_err(|e| TestCaseError::fail(format!("{order}: {e}")))?;
        }
    }

    /// Early splat elimination draws the renderer's list (the pre-pass
    /// walk, `collect_kept`) reversed: that sequence is exactly the reverse
    /// of the back-to-front walk, and it is front to back (every voxel before
    /// its farther face neighbours), orthographic and perspective.
    #[test]
    fn reversed_walks_are_front_to_back(
        dims in dims_strategy(), d in dir_strategy(), sp in spacing_strategy(),
        eye in eye_strategy(), persp in any::<bool>()
    ) {
        let view = if persp {
            OrderView::Perspective { eye, spacing: sp }
        } else {
            OrderView::orthographic(d, sp)
        };
        let mut scratch = sort::SortScratch::default();
        for order in Order::ALL {
            let b2f = collect(order, dims, &view);
            let mut listed = Vec::new();
            collect_kept(order, dims, &view, &|_| true, &|i| Some(i), &mut scratch, &mut listed);
            let f2b: Vec<u64> = listed.iter().rev().map(|x| x.0).collect();
            let mut want = b2f.clone();
            want.reverse();
            prop_assert_eq!(&f2b, &want, "{}", order);
            let nearer_first = |v: [u64; 3], a: usize| -> Option<bool> {
                match view {
                    OrderView::Orthographic { w } => {
                        if w[a] > 0.0 { Some(false) } else if w[a] < 0.0 { Some(true) } else { None }
                    }
                    OrderView::Perspective { eye, .. } => Some(eye[a] >= v[a] as f64 + 0.5),
                }
            };
            // check_faces(order, farther): "farther neighbours first"; front
            // to back is the same check with near and far swapped.
            check_faces(&f2b, dims, nearer_first)
                .map_err(|e| TestCaseError::fail(format!("{order} front to back: {e}")))?;
        }
    }

    #[test]
    fn perspective_orders_are_back_to_front(
        dims in dims_strategy(), eye in eye_strategy(), sp in spacing_strategy()
    ) {
        let view = OrderView::Perspective { eye, spacing: sp };
        for order in Order::ALL {
            let o = collect(order, dims, &view);
            // v + e_a is farther iff the eye is on v's side of their shared
            // face at v_a + 1/2.
            check_faces(&o, dims, |v, a| Some(eye[a] < v[a] as f64 + 0.5))
                .map_err(|e| TestCaseError::fail(format!("{order}: {e}")))?;
        }
    }

    /// The DDA's view-aligned bound: a voxel drawn earlier is never more
    /// than `2 w_R` nearer than one drawn later (when no clamp is active).
    #[test]
    fn dda_is_depth_sorted_to_two_minor_steps(
        dims in [2u64..12, 2u64..12, 2u64..12], d in dir_strategy(), sp in spacing_strategy()
    ) {
        let view = OrderView::orthographic(d, sp);
        let oct = octants(dims, &view)[0];
        let [ap, a_s, ar] = dda::axes(&oct);
        let (w_p, w_s, w_r) = (oct.weight[ap], oct.weight[a_s], oct.weight[ar]);
        let (ratio_s, ratio_p) = dda::ratios(&oct);
        prop_assume!(w_r > 0.0 && ratio_s == w_r / w_s && ratio_p == w_r / w_p);
        let order = collect(Order::Dda, dims, &view);
        let progress = |idx: u64| {
            let g = [idx % dims[0], idx / dims[0] % dims[1], idx / (dims[0] * dims[1])];
            // Distance from the far corner plane: sum_a w_a (slabs from the far side).
            (0..3)
                .map(|a| {
                    let from_far = if oct.far_high[a] { dims[a] - 1 - g[a] } else { g[a] };
                    oct.weight[a] * from_far as f64
                })
                .sum::<f64>()
        };
        let mut run_max = f64::NEG_INFINITY;
        for &i in &order {
            let p = progress(i);
            prop_assert!(run_max - p < 2.0 * w_r * (1.0 + 1e-9) + 1e-12,
                "drawn after a voxel {} nearer (bound {})", run_max - p, 2.0 * w_r);
            run_max = run_max.max(p);
        }
    }

    /// The sorts put depth in non-increasing order (to their quantum).
    #[test]
    fn sorts_follow_depth(
        dims in dims_strategy(), d in dir_strategy(), sp in spacing_strategy(),
        eye in eye_strategy(), persp in any::<bool>()
    ) {
        let view = if persp {
            OrderView::Perspective { eye, spacing: sp }
        } else {
            OrderView::orthographic(d, sp)
        };
        let depth = |idx: u64| {
            let g = [idx % dims[0], idx / dims[0] % dims[1], idx / (dims[0] * dims[1])];
            view.depth_key(g.map(|x| x as f64))
        };
        let all: Vec<f64> = (0..dims.iter().product()).map(depth).collect();
        let span = all.iter().cloned().fold(0.0f64, f64::max) + all.iter().cloned().fold(0.0f64, |m, x| m.max(-x));
        for (order, quantum) in [(Order::Quicksort, 1e-9), (Order::Radix, 2.0 / sort::RADIX_BUCKETS as f64)] {
            let o = collect(order, dims, &view);
            for w in o.windows(2) {
                prop_assert!(depth(w[0]) >= depth(w[1]) - quantum * span - 1e-12,
                    "{order}: depth rises {} -> {}", depth(w[0]), depth(w[1]));
            }
        }
    }
}

#[test]
fn culling_keeps_order_and_drops_voxels() {
    let dims = [5, 4, 3];
    let view = OrderView::orthographic([0.3, -0.5, 0.8], [1.0; 3]);
    for order in Order::ALL {
        let full = collect(order, dims, &view);
        let mut kept = Vec::new();
        visit_kept(order, dims, &view, |i| i % 3 != 0, |i| kept.push(i));
        let expect: Vec<u64> = full.iter().cloned().filter(|i| i % 3 != 0).collect();
        if matches!(order, Order::Axis | Order::Dda) {
            assert_eq!(kept, expect, "{order}");
        } else {
            // Sorting fewer voxels may break depth ties differently.
            let mut a = kept.clone();
            let mut b = expect.clone();
            a.sort();
            b.sort();
            assert_eq!(a, b, "{order}");
        }
    }
}

#[test]
fn for_each_bit_visits_the_set_bits_in_range() {
    let line = [0b1011u64 | 1 << 63, 1 | 1 << 5, 1 << 7];
    let collect = |lo, hi, desc| {
        let mut v = Vec::new();
        mask::for_each_bit(&line, lo, hi, desc, |b, rank| {
            // rank: set bits of the whole line below b.
            let below: u32 = (0..b)
                .map(|x| (line[(x / 64) as usize] >> (x % 64) & 1) as u32)
                .sum();
            assert_eq!(rank, below as usize, "bit {b}");
            v.push(b)
        });
        v
    };
    assert_eq!(collect(0, 150, false), vec![0, 1, 3, 63, 64, 69, 135]);
    assert_eq!(collect(1, 135, false), vec![1, 3, 63, 64, 69]);
    assert_eq!(collect(1, 136, true), vec![135, 69, 64, 63, 3, 1]);
    assert_eq!(collect(64, 64, true), Vec::<u64>::new());
    assert_eq!(collect(63, 65, false), vec![63, 64]);
}

/// The paper's 2-D example (Fig. 5, Δx/Δy = 0.5): columns join every second
/// step, so voxel (column c, row r) is drawn at step 2c + r.
#[test]
fn dda_matches_fig5_in_2d() {
    // A 4 x 1 x 6 grid seen along (1, 0, 0.5): P = x (w 1), S = z (w 0.5),
    // R = y (one voxel, w 0, so d_S's increment is clamped to 1/n_R = 1 and
    // the step depth is h = 0.5, d_P's increment 0.5). Plane p (from the far
    // side) joins at step 2p, column s at step s of its plane: voxel
    // (x, z) is drawn at step 2 (3 - x) + (5 - z), the 2-D walk of Fig. 5.
    let dims = [4, 1, 6];
    let view = OrderView::orthographic([1.0, 0.0, 0.5], [1.0; 3]);
    let order = collect(Order::Dda, dims, &view);
    let step = |idx: u64| 2 * (3 - idx % 4) + (5 - idx / 4);
    for w in order.windows(2) {
        assert!(step(w[0]) <= step(w[1]), "{:?}", order);
    }
}
