//! A compositing strategy as data: rounds of `(from, to, what)` exchanges.
//!
//! Every node starts holding segment lists for the whole screen. A
//! [`RoundKind::Lists`] round sends lists of sub-rectangles; afterwards each
//! node keeps only the lists of `keep[node]` and merges what it received into
//! them (every received rectangle equals the receiver's `keep`). A
//! [`RoundKind::Composite`] round has no messages: each node final-composites
//! the lists it holds into pixels. A [`RoundKind::Gather`] round sends those
//! pixels to the root, which assembles the image.
//!
//! The same schedule runs in-process ([`exec`](super::exec)), in a
//! discrete-event simulator (charge each exchange to a network model), or
//! over a real transport.

use crate::base::Rect;

use super::region::{area, contains, overlaps};

/// What one message carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Payload {
    /// The sender's segment lists of this rectangle.
    Lists(Rect),
    /// The sender's composited pixels of this rectangle.
    Pixels(Rect),
}

impl Payload {
    /// The rectangle carried.
    pub fn rect(&self) -> Rect {
        match self {
            Payload::Lists(r) | Payload::Pixels(r) => *r,
        }
    }
}

/// One message of a round.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Exchange {
    /// Sending rank.
    pub from: usize,
    /// Receiving rank.
    pub to: usize,
    /// What it sends.
    pub what: Payload,
}

/// What a round does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoundKind {
    /// Exchange lists, keep `keep[node]`, merge what arrives.
    Lists,
    /// Every node composites the lists it holds into pixels (no messages).
    Composite,
    /// Send pixels to the root.
    Gather,
}

/// One round: all its messages can be in flight at once.
#[derive(Debug, Clone, PartialEq)]
pub struct Round {
    /// What the round does.
    pub kind: RoundKind,
    /// Short name for reports ("fold", "swap 0", "gather").
    pub label: String,
    /// The messages.
    pub sends: Vec<Exchange>,
    /// For [`RoundKind::Lists`]: the region each node holds lists for
    /// afterwards (`None`: nothing). Empty for the other kinds.
    pub keep: Vec<Option<Rect>>,
}

/// A whole compositing run.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// Number of nodes (ranks `0..nodes`).
    pub nodes: usize,
    /// The screen.
    pub image: Rect,
    /// The rank that ends with the image.
    pub root: usize,
    /// The rounds, in order.
    pub rounds: Vec<Round>,
}

impl Schedule {
    /// Checks the protocol: senders hold what they send, lists arrive for
    /// exactly the receiver's kept region, kept regions shrink, the composited
    /// regions tile the screen once, and the root gathers all of them.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.nodes;
        let mut lists: Vec<Option<Rect>> = vec![Some(self.image); n];
        let mut pixels: Vec<Vec<Rect>> = vec![Vec::new(); n];
        for (k, round) in self.rounds.iter().enumerate() {
            let at = |m: String| format!("round {k} ({}): {m}", round.label);
            for e in &round.sends {
                if e.from >= n || e.to >= n || e.from == e.to {
                    return Err(at(format!("bad ranks in {e:?}")));
                }
            }
            match round.kind {
                RoundKind::Lists => {
                    if round.keep.len() != n {
                        return Err(at("keep must have one entry per node".into()));
                    }
                    for e in &round.sends {
                        let Payload::Lists(r) = e.what else {
                            return Err(at(format!("pixels sent in a lists round: {e:?}")));
                        };
                        if !lists[e.from].is_some_and(|h| contains(&h, &r)) {
                            return Err(at(format!("{} sends {r:?} it does not hold", e.from)));
                        }
                        if round.keep[e.to] != Some(r) {
                            return Err(at(format!(
                                "{} receives {r:?} but keeps {:?}",
                                e.to, round.keep[e.to]
                            )));
                        }
                    }
                    for (node, keep) in round.keep.iter().enumerate() {
                        if let Some(kr) = keep {
                            if !lists[node].is_some_and(|h| contains(&h, kr)) {
                                return Err(at(format!(
                                    "{node} keeps {kr:?} outside what it holds"
                                )));
                            }
                        }
                    }
                    lists.clone_from(&round.keep);
                }
                RoundKind::Composite => {
                    for (node, l) in lists.iter_mut().enumerate() {
                        if let Some(r) = l.take() {
                            pixels[node].push(r);
                        }
                    }
                    let all: Vec<Rect> = pixels
                        .iter()
                        .flatten()
                        .copied()
                        .filter(|r| area(r) > 0)
                        .collect();
                    if all.iter().map(area).sum::<usize>() != area(&self.image) {
                        return Err(at("composited regions do not cover the screen".into()));
                    }
                    for (i, a) in all.iter().enumerate() {
                        if all[i + 1..].iter().any(|b| overlaps(a, b)) {
                            return Err(at(format!("{a:?} composited twice")));
                        }
                    }
                }
                RoundKind::Gather => {
                    for e in &round.sends {
                        let Payload::Pixels(r) = e.what else {
                            return Err(at(format!("lists sent in a gather round: {e:?}")));
                        };
                        if e.to != self.root || !pixels[e.from].contains(&r) {
                            return Err(at(format!("bad gather {e:?}")));
                        }
                        pixels[e.from].retain(|p| *p != r);
                        pixels[self.root].push(r);
                    }
                }
            }
        }
        let at_root: usize = pixels[self.root].iter().map(area).sum();
        if at_root != area(&self.image)
            || pixels
                .iter()
                .enumerate()
                .any(|(i, p)| i != self.root && p.iter().any(|r| area(r) > 0))
        {
            return Err("the root does not end with the whole image".into());
        }
        Ok(())
    }

    /// Messages in all rounds.
    pub fn messages(&self) -> usize {
        self.rounds.iter().map(|r| r.sends.len()).sum()
    }
}
