//! Direct send: one round, everybody to everybody.
//!
//! The screen is cut into `n` row strips of about equal pixel count (or
//! equal work, given a per-pixel cost map); node `i` owns strip `i`. Every
//! node sends each other node the lists of that node's strip (`n (n - 1)`
//! messages, most of them small when the data is spatially coherent and the
//! codec collapses empty pixels), every owner merges the `n` contributions,
//! composites its strip, and sends the pixels to the root.

use crate::base::Rect;

use super::super::region::{area, strips};
use super::super::schedule::{Exchange, Payload, Round, RoundKind, Schedule};
use super::Strategy;

/// Direct send, optionally balanced by a per-pixel cost map.
#[derive(Debug, Clone, Default)]
pub struct DirectSend {
    /// Per-pixel cost over the whole image (row-major), e.g. segment counts
    /// of the previous frame; strips then hold about equal cost. Ignored
    /// unless its length is the image's area.
    pub cost: Option<Vec<f64>>,
}

impl DirectSend {
    /// The strips node `0..n` own.
    pub fn regions(&self, nodes: usize, image: Rect) -> Vec<Rect> {
        let w = image.width() as usize;
        let rows: Option<Vec<f64>> = self
            .cost
            .as_ref()
            .filter(|c| c.len() == area(&image))
            .map(|c| c.chunks(w.max(1)).map(|row| row.iter().sum()).collect());
        strips(&image, nodes, rows.as_deref())
    }
}

impl Strategy for DirectSend {
    fn name(&self) -> &'static str {
        "direct-send"
    }

    fn preserves_order(&self) -> bool {
        true
    }

    fn schedule(&self, nodes: usize, image: Rect) -> Schedule {
        let regions = self.regions(nodes, image);
        let mut sends = Vec::new();
        for from in 0..nodes {
            for (to, r) in regions.iter().enumerate() {
                if to != from && area(r) > 0 {
                    sends.push(Exchange {
                        from,
                        to,
                        what: Payload::Lists(*r),
                    });
                }
            }
        }
        Schedule {
            nodes,
            image,
            root: 0,
            rounds: vec![
                Round {
                    kind: RoundKind::Lists,
                    label: "send".into(),
                    sends,
                    keep: regions.iter().map(|r| Some(*r)).collect(),
                },
                super::composite(),
                super::gather(&regions, 0),
            ],
        }
    }
}
