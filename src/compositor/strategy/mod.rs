//! Compositing strategies behind one interface, chosen as a typed value
//! ([`Compositing`], parsed once; [`from_name`] parses and builds, [`list`]
//! describes). A strategy only *describes* the exchange as a [`Schedule`];
//! running it is the executor's job.

mod binary_swap;
mod choice;
mod direct_send;
mod master;
mod radix_k;

pub use binary_swap::BinarySwap;
pub use choice::{Compositing, GroupSize};
pub use direct_send::DirectSend;
pub use master::Master;
pub use radix_k::{factors as radix_factors, RadixK, DEFAULT_K as RADIX_K_DEFAULT};

use crate::base::Rect;

use super::schedule::Schedule;

/// A compositing strategy.
pub trait Strategy: Send + Sync {
    /// The name [`from_name`] knows it by.
    fn name(&self) -> &'static str;
    /// The name with its parameters, as [`from_name`] takes it back
    /// (`radix-k:4`); the plain name for strategies without parameters.
    fn label(&self) -> String {
        self.name().to_string()
    }
    /// Whether the result keeps visibility order exactly (required for
    /// translucent volumes: "over" is not commutative). Strategies that merge
    /// depth-sorted segment lists do; ones that blend pre-composited images
    /// in rank order would not, for cells spread over nodes arbitrarily.
    fn preserves_order(&self) -> bool;
    /// Whether an executor of visibility-ranked layers should composite
    /// the layers a rank holds whose ranks are adjacent after every lists
    /// round (IceT's per-round compositing, where it is exact for any
    /// placement). Segment lists ignore it (merging lists is exact anyway).
    fn merges_early(&self) -> bool {
        false
    }
    /// The rounds for `nodes` nodes compositing `image` (`nodes >= 1`).
    fn schedule(&self, nodes: usize, image: Rect) -> Schedule;
}

/// Names and one-line descriptions of every strategy.
pub fn list() -> &'static [(&'static str, &'static str)] {
    &[
        (
            "direct-send",
            "each node owns a row strip of the screen; every node sends each strip's lists to its owner (1 round, n(n-1) messages), then gather",
        ),
        (
            "binary-swap",
            "log2(n) rounds of pairwise half swaps (rank XOR 2^i); extra nodes of a non-power-of-two count fold into a partner first; then gather",
        ),
        (
            "radix-k",
            "rounds with group sizes k_i (product n, each at most k unless a prime factor of n is larger): each group splits its region into k_i pieces, every member sends each piece to its owner; layers adjacent in visibility order are composited after each round; `radix-k:K` sets k (default 8, IceT's); then gather",
        ),
        (
            "master",
            "every node sends all it holds to rank 0 (the master), which composites alone (the sort-last grid paper); 1 round, n-1 messages",
        ),
    ]
}

/// The strategy called `name` (a [`Compositing`]'s text form).
pub fn from_name(name: &str) -> Result<Box<dyn Strategy>, String> {
    Ok(name.parse::<Compositing>()?.build())
}

/// The gather round shared by all strategies: every non-root node that
/// composited a non-empty region sends its pixels to the root.
fn gather(owned: &[Rect], root: usize) -> super::schedule::Round {
    use super::schedule::{Exchange, Payload, Round, RoundKind};
    Round {
        kind: RoundKind::Gather,
        label: "gather".into(),
        sends: owned
            .iter()
            .enumerate()
            .filter(|(node, r)| *node != root && super::region::area(r) > 0)
            .map(|(node, r)| Exchange {
                from: node,
                to: root,
                what: Payload::Pixels(*r),
            })
            .collect(),
        keep: Vec::new(),
    }
}

/// The composite round (no messages).
fn composite() -> super::schedule::Round {
    super::schedule::Round {
        kind: super::schedule::RoundKind::Composite,
        label: "composite".into(),
        sends: Vec::new(),
        keep: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compositor::region::screen;

    #[test]
    fn every_schedule_is_valid() {
        for (name, _) in list() {
            let s = from_name(name).unwrap();
            assert!(s.preserves_order());
            for n in 1..=20 {
                for img in [
                    screen(100, 100),
                    screen(900, 300),
                    screen(3, 2),
                    screen(1, 1),
                ] {
                    let sch = s.schedule(n, img);
                    sch.validate()
                        .unwrap_or_else(|e| panic!("{name} n={n} {img:?}: {e}"));
                }
            }
        }
        assert!(from_name("nope").err().unwrap().contains("binary-swap"));
        assert_eq!(from_name("radix-k:3").unwrap().label(), "radix-k:3");
        assert_eq!(from_name("radix-k").unwrap().label(), "radix-k:8");
        for bad in ["radix-k:1", "radix-k:x", "radix-k:"] {
            assert!(
                from_name(bad).err().unwrap().contains("from 2 to 4096"),
                "{bad}"
            );
        }
    }
}
