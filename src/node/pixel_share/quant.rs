//! Depth codes: `u16` over the frame's depth range, always rounded up
//! ([`DepthQuant`]), [`NOT_REACHED`] meaning "not reached".

/// The code of "not reached / not terminated".
pub const NOT_REACHED: u16 = u16::MAX;

/// `u16` codes for depths over `[z0, z1]`, rounded up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthQuant {
    z0: f32,
    step: f32,
}

impl DepthQuant {
    /// Codes over the depth range `[z0, z1]` of a frame (any depth a segment
    /// can have lies at or below `z1`; depths below `z0` get code 0).
    pub fn new(z0: f32, z1: f32) -> DepthQuant {
        let span = if z1.is_finite() && z0.is_finite() && z1 > z0 {
            z1 - z0
        } else {
            1.0
        };
        DepthQuant {
            z0: if z0.is_finite() { z0 } else { 0.0 },
            // One step of headroom so that z1 itself is representable after
            // rounding up.
            step: span / (NOT_REACHED - 2) as f32,
        }
    }

    /// Width of the coded depth range.
    pub fn span(&self) -> f32 {
        self.step * (NOT_REACHED - 2) as f32
    }

    /// The smallest code whose value is `>= z` (`NOT_REACHED` for `+inf`, NaN,
    /// or depths beyond the range).
    pub fn up(&self, z: f32) -> u16 {
        if z.is_nan() || z == f32::INFINITY {
            return NOT_REACHED;
        }
        let q = ((z - self.z0) / self.step).ceil();
        if q <= 0.0 {
            return 0;
        }
        if q >= (NOT_REACHED - 1) as f32 {
            return if self.value(NOT_REACHED - 1) >= z {
                NOT_REACHED - 1
            } else {
                NOT_REACHED
            };
        }
        let mut q = q as u16;
        // Float rounding in the division: step up until the value covers z,
        // and down while the code below still does.
        while q < NOT_REACHED - 1 && self.value(q) < z {
            q += 1;
        }
        while q > 0 && self.value(q - 1) >= z {
            q -= 1;
        }
        if self.value(q) < z {
            NOT_REACHED
        } else {
            q
        }
    }

    /// The depth of code `q` (`+inf` for `NOT_REACHED`).
    #[inline]
    pub fn value(&self, q: u16) -> f32 {
        if q == NOT_REACHED {
            f32::INFINITY
        } else {
            self.z0 + q as f32 * self.step
        }
    }
}
