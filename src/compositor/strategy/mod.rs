//! Compositing strategies behind one interface, selected in one place
//! ([`from_name`], [`list`]). A strategy only *describes* the exchange as a
//! [`Schedule`]; running it is the executor's job.

mod binary_swap;
mod direct_send;
mod master;

pub use binary_swap::BinarySwap;
pub use direct_send::DirectSend;
pub use master::Master;

use crate::render::cell::scan::Rect;

use super::schedule::Schedule;

/// A compositing strategy.
pub trait Strategy: Send + Sync {
    /// The name [`from_name`] knows it by.
    fn name(&self) -> &'static str;
    /// Whether the result keeps visibility order exactly (required for
    /// translucent volumes: "over" is not commutative). Strategies that merge
    /// depth-sorted segment lists do; ones that blend pre-composited images
    /// in rank order would not, for cells spread over nodes arbitrarily.
    fn preserves_order(&self) -> bool;
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
            "master",
            "every node sends all it holds to rank 0 (the master), which composites alone (the sort-last grid paper); 1 round, n-1 messages",
        ),
    ]
}

/// The strategy called `name`, with default parameters.
pub fn from_name(name: &str) -> Result<Box<dyn Strategy>, String> {
    match name {
        "direct-send" | "direct" => Ok(Box::new(DirectSend::default())),
        "binary-swap" | "bswap" => Ok(Box::new(BinarySwap)),
        "master" => Ok(Box::new(Master)),
        _ => Err(format!(
            "unknown compositing strategy `{name}`; choose one of: {}",
            list()
                .iter()
                .map(|(n, _)| *n)
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
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
    }
}
