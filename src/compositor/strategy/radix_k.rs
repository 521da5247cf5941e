//! Radix-k (Peterka et al. 2009; IceT's `ICET_RADIXK_STRATEGY`): rounds
//! with factors `k_0 k_1 … k_{m-1} = n`. In round `i` the ranks form groups
//! of `k_i` that differ only in their `i`-th mixed-radix digit
//!
//! ```text
//! digit_i(r) = (r / s_i) mod k_i,   s_i = k_0 … k_{i-1}   (s_0 = 1)
//! ```
//!
//! so a group's members share the region the earlier rounds left them
//! (it depends on digits `0..i` only). The group cuts that region into
//! `k_i` pieces across its longer side ([`pieces`]); member `j` keeps piece
//! `j` and sends piece `m` of what it holds to member `m`, for all `m != j`:
//! `k_i (k_i - 1)` messages a group. After the last round every rank holds
//! `1/n` of the screen with everybody's data in it, composites it, and the
//! root gathers the pieces. `k = 2` on a power of two is binary swap; one
//! factor `k_0 = n` is direct send.
//!
//! Round 0 groups consecutive ranks (digit 0 varies fastest), as IceT's
//! ordered radix-k does, so that data adjacent in the composite order meets
//! early when ranks follow it.
//!
//! # Factors, and node counts that are not powers of `k`
//!
//! [`factors`] takes, while something is left, the largest factor `<= k`
//! that divides what is left; a prime factor larger than `k` becomes one
//! round of its own (a direct send among that many ranks). So every `n` is
//! handled, without idle ranks (binary swap's fold is not needed): `n = 5`
//! with `k = 4` is one round of 5, `n = 12` with `k = 8` is `6 · 2`.
//!
//! # Order
//!
//! As with the other strategies, what moves are the sender's partials
//! cropped to the piece (segment lists, or visibility-ranked layers), so
//! the final composite sees every partial of its piece and orders them by
//! depth (lists) or by visibility rank (layers). The layer executor may in
//! addition merge layers whose ranks are adjacent after each round
//! ([`Strategy::merges_early`]), which is IceT's per-round compositing
//! restricted to what is exact for any brick placement.

use crate::base::Rect;

use super::super::region::{area, pieces};
use super::super::schedule::{Exchange, Payload, Round, RoundKind, Schedule};
use super::Strategy;

/// IceT's default `k` (`ICET_MAGIC_K_DEFAULT`, IceTConfig.h).
pub const DEFAULT_K: usize = 8;

/// Radix-k with target factor `k` (`k >= 2`).
#[derive(Debug, Clone, Copy)]
pub struct RadixK {
    /// The target group size.
    pub k: usize,
}

impl Default for RadixK {
    fn default() -> Self {
        RadixK { k: DEFAULT_K }
    }
}

/// The rounds' group sizes for `n` ranks and target `k`: while the rest
/// `m > 1`, the largest `f <= k` dividing `m`, or, if none does, `m`'s
/// smallest prime factor (then larger than `k`). Their product is `n`;
/// `n = 1` gives no rounds.
pub fn factors(n: usize, k: usize) -> Vec<usize> {
    let k = k.max(2);
    let mut m = n.max(1);
    let mut out = Vec::new();
    while m > 1 {
        let f = (2..=k.min(m))
            .rev()
            .find(|&f| m.is_multiple_of(f))
            .unwrap_or_else(|| (2..=m).find(|&p| m.is_multiple_of(p)).unwrap_or(m));
        out.push(f);
        m /= f;
    }
    out
}

impl Strategy for RadixK {
    fn name(&self) -> &'static str {
        "radix-k"
    }

    fn label(&self) -> String {
        format!("radix-k:{}", self.k)
    }

    fn preserves_order(&self) -> bool {
        true
    }

    fn merges_early(&self) -> bool {
        true
    }

    fn schedule(&self, nodes: usize, image: Rect) -> Schedule {
        let n = nodes.max(1);
        let mut held: Vec<Rect> = vec![image; n];
        let mut rounds = Vec::new();
        let mut stride = 1usize;
        for (i, &f) in factors(n, self.k).iter().enumerate() {
            let mut sends = Vec::new();
            let mut keep = held.clone();
            for r in 0..n {
                let digit = (r / stride) % f;
                let base = r - digit * stride;
                let cut = pieces(&held[r], f);
                keep[r] = cut[digit];
                for (j, piece) in cut.iter().enumerate() {
                    if j != digit && area(piece) > 0 {
                        sends.push(Exchange {
                            from: r,
                            to: base + j * stride,
                            what: Payload::Lists(*piece),
                        });
                    }
                }
            }
            rounds.push(Round {
                kind: RoundKind::Lists,
                label: format!("radix {i} (k={f})"),
                sends,
                keep: keep.iter().map(|r| Some(*r)).collect(),
            });
            held = keep;
            stride *= f;
        }
        rounds.push(super::composite());
        rounds.push(super::gather(&held, 0));
        Schedule {
            nodes: n,
            image,
            root: 0,
            rounds,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compositor::region::screen;
    use proptest::prelude::{prop_assert, prop_assert_eq, proptest};

    #[test]
    fn factors_multiply_to_n_and_stay_within_k_unless_prime() {
        assert_eq!(factors(1, 8), Vec::<usize>::new());
        assert_eq!(factors(5, 4), vec![5]);
        assert_eq!(factors(12, 8), vec![6, 2]);
        assert_eq!(factors(64, 4), vec![4, 4, 4]);
        assert_eq!(factors(16, 2), vec![2, 2, 2, 2]);
        for n in 1..200 {
            for k in 2..10 {
                let f = factors(n, k);
                assert_eq!(f.iter().product::<usize>(), n, "n={n} k={k}");
                for &x in &f {
                    let prime = (2..x).all(|d| x % d != 0);
                    assert!(x <= k || prime, "n={n} k={k}: {f:?}");
                }
            }
        }
    }

    proptest! {
        /// Every radix-k schedule passes the protocol check, and its rounds
        /// send `k_i - 1` pieces per rank at most.
        #[test]
        fn schedules_are_valid(n in 1usize..40, k in 2usize..9, w in 1u32..60, h in 1u32..60) {
            let s = RadixK { k }.schedule(n, screen(w, h));
            prop_assert!(s.validate().is_ok(), "{:?}", s.validate());
            let f = factors(n, k);
            prop_assert_eq!(s.rounds.len(), f.len() + 2);
            for (round, &k_i) in s.rounds.iter().zip(&f) {
                prop_assert!(round.sends.len() <= n * (k_i - 1));
            }
        }
    }
}
