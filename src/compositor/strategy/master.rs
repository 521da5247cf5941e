//! Master: every node sends everything it holds for the whole screen to the
//! root, which composites alone (the paper's sort-last grid renderer, where
//! the slaves' subimages go to one master node that blends them in
//! visibility order). One round of `n - 1` messages; no gather.

use crate::base::Rect;

use super::super::schedule::{Exchange, Payload, Round, RoundKind, Schedule};
use super::Strategy;

/// Direct send of everything to rank 0.
#[derive(Debug, Clone, Copy, Default)]
pub struct Master;

impl Strategy for Master {
    fn name(&self) -> &'static str {
        "master"
    }

    fn preserves_order(&self) -> bool {
        true
    }

    fn schedule(&self, nodes: usize, image: Rect) -> Schedule {
        let send = Round {
            kind: RoundKind::Lists,
            label: "to master".into(),
            sends: (1..nodes)
                .map(|k| Exchange {
                    from: k,
                    to: 0,
                    what: Payload::Lists(image),
                })
                .collect(),
            keep: (0..nodes).map(|k| (k == 0).then_some(image)).collect(),
        };
        Schedule {
            nodes,
            image,
            root: 0,
            rounds: vec![send, super::composite(), super::gather(&[image], 0)],
        }
    }
}
