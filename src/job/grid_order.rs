//! `--order`, shared by the grid renderers: a slicer's compositing order or
//! a splatting visit order. [`GridOrder`] holds both kinds and each
//! renderer refuses the other's.

use clap::ValueEnum;

use crate::render::slicing;
use crate::render::splat::order::Order as SplatOrder;

/// `--order`: a slicer's compositing order or a splatting visit order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum GridOrder {
    /// Slicers: front to back, `C += (1 - A) C_s`, `A += (1 - A) A_s`, with
    /// early ray termination once `A` reaches the threshold.
    FrontToBack,
    /// Slicers: back to front with blend factors `(1, 1 - A_s)` (the
    /// paper's OpenGL blending); no early termination possible.
    BackToFront,
    /// Splat: Westover's axis-aligned slices, far to near.
    Axis,
    /// Splat: the DDA view-aligned order (splatting-dda-order.txt; default).
    Dda,
    /// Splat: a full depth sort (comparison sort, the paper's quicksort).
    Sort,
    /// Splat: a full depth sort by radix (counting) sort of quantised depths.
    Radix,
}

impl GridOrder {
    /// The slicers' compositing order (default front to back); an error for
    /// a splatting order.
    pub fn compositing(o: Option<GridOrder>) -> anyhow::Result<slicing::Order> {
        match o {
            None | Some(GridOrder::FrontToBack) => Ok(slicing::Order::FrontToBack),
            Some(GridOrder::BackToFront) => Ok(slicing::Order::BackToFront),
            Some(x) => anyhow::bail!(
                "--order {} is a splatting order (--renderer splat); the slicers take \
                 front-to-back or back-to-front",
                x.to_possible_value()
                    .map_or(String::new(), |v| v.get_name().into())
            ),
        }
    }

    /// The splatting visit order (default DDA); an error for a compositing
    /// order.
    pub fn splat(o: Option<GridOrder>) -> anyhow::Result<SplatOrder> {
        match o {
            None | Some(GridOrder::Dda) => Ok(SplatOrder::Dda),
            Some(GridOrder::Axis) => Ok(SplatOrder::Axis),
            Some(GridOrder::Sort) => Ok(SplatOrder::Quicksort),
            Some(GridOrder::Radix) => Ok(SplatOrder::Radix),
            Some(x) => anyhow::bail!(
                "--order {} is a slicer's compositing order; --renderer splat takes \
                 axis, dda, sort or radix (splats go front to back with --ert < 1, back to front with --ert 1)",
                x.to_possible_value()
                    .map_or(String::new(), |v| v.get_name().into())
            ),
        }
    }
}
