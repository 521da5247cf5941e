//! The one validation layer for command-line options.
//!
//! clap checks types and listed values; this module checks what clap cannot:
//! ranges, and what a *combination* of options means. Every command's args
//! implement [`Validate`]; `run` calls [`apply`] (errors stop the command,
//! warnings are printed on stderr), and `execute` (also used by `sweep` for
//! every run) calls [`check`] so a sweep fails or warns exactly as the
//! command would. Nothing is clamped or dropped silently: an option either
//! does what it says, or the user gets an error that says what to do, or a
//! warning that says what will happen instead.
//!
//! Adding options (a new renderer, a transport): add their checks to the
//! command's `impl Validate` (or implement [`Validate`] on a flattened args
//! struct and call its `validate` from there), using the helpers below:
//!
//! - [`at_least`], [`unit_interval`], [`image_size`]: single values;
//! - [`ert_mode`]: what `--ert T` means (the one place: `T` in (0, 1),
//!   ERT on; exactly 1, off; anything else, an error);
//! - [`needs`]: an option that only means something when another one is on
//!   (error, naming the option that would turn it on);
//! - [`Checks::ignored`]: an option that does nothing in this combination
//!   (warning, saying so).
//!
//! Options of `cluster` and `render` that only matter with another setting
//! (a structure, sharing, a transport, a clock, a renderer, a series) are
//! rows of one table, [`super::rules`], which applies [`needs`] and
//! [`Checks::ignored`] and whose tests walk every row: a new such option is
//! a new row there.

use std::fmt::Display;

/// Warnings collected while validating one command line.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Checks {
    warnings: Vec<String>,
}

impl Checks {
    /// No warnings yet.
    pub fn new() -> Checks {
        Checks::default()
    }

    /// Records a warning (printed as `warning: MSG`).
    pub fn warn(&mut self, msg: impl Into<String>) {
        self.warnings.push(msg.into());
    }

    /// `option` was given but does nothing because `why`.
    pub fn ignored(&mut self, option: &str, why: &str) {
        self.warn(format!("{option} has no effect: {why}"));
    }

    /// The warnings, in the order found.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

/// Options that can be checked before any work.
pub trait Validate {
    /// The typed values validation decides once (the ERT mode, the
    /// compositor), which the job then runs from ([`Valid::parsed`])
    /// instead of deciding again from the raw options.
    type Parsed: std::fmt::Debug;

    /// Returns an error for a value or combination that cannot run, and
    /// records a warning for one that runs but not as the user may expect;
    /// else the typed values.
    fn validate(&self, c: &mut Checks) -> anyhow::Result<Self::Parsed>;
}

#[cfg(test)]
thread_local! {
    /// Validations run on this thread (tests count them per command).
    static CHECKS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// How many times [`check`] ran on this thread (tests: a command
/// validates its options once).
#[cfg(test)]
pub(crate) fn checks_on_this_thread() -> usize {
    CHECKS.with(|c| c.get())
}

/// Validates `args`; returns the warnings.
pub fn check<T: Validate + ?Sized>(args: &T) -> anyhow::Result<Vec<String>> {
    Ok(Valid::new(args)?.warnings)
}

/// Options that passed the validation layer, with its warnings and the
/// typed values it decided: what a job runs from
/// (`Valid<RenderArgs>::run`, `Valid<ClusterArgs>::load`), so that every
/// run validates its options exactly once and nothing below decides them
/// again.
#[derive(Debug)]
pub struct Valid<'a, T: Validate + ?Sized> {
    args: &'a T,
    parsed: T::Parsed,
    warnings: Vec<String>,
}

impl<'a, T: Validate + ?Sized> Valid<'a, T> {
    /// Validates `args`: the error, or the options with the warnings and
    /// the typed values.
    pub fn new(args: &'a T) -> anyhow::Result<Self> {
        #[cfg(test)]
        CHECKS.with(|c| c.set(c.get() + 1));
        let mut c = Checks::new();
        let parsed = args.validate(&mut c)?;
        Ok(Valid {
            args,
            parsed,
            warnings: c.warnings,
        })
    }

    /// The options.
    pub fn args(&self) -> &'a T {
        self.args
    }

    /// The typed values validation decided.
    pub fn parsed(&self) -> &T::Parsed {
        &self.parsed
    }

    /// The warnings, in the order found.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Prints the warnings on stderr (`warning: ...`).
    pub fn print_warnings(&self) {
        for w in &self.warnings {
            super::output::warn(w.clone());
        }
    }
}

/// Validates `args` and prints the warnings on stderr.
pub fn apply<T: Validate + ?Sized>(args: &T) -> anyhow::Result<()> {
    for w in check(args)? {
        super::output::warn(w);
    }
    Ok(())
}

/// `option` must be at least `min`.
pub fn at_least<T: PartialOrd + Display>(option: &str, v: T, min: T) -> anyhow::Result<()> {
    anyhow::ensure!(v >= min, "{option} {v}: must be at least {min}");
    Ok(())
}

/// `option` must be in (0, 1].
pub fn unit_interval(option: &str, v: f32, hint: &str) -> anyhow::Result<()> {
    anyhow::ensure!(
        v.is_finite() && v > 0.0 && v <= 1.0,
        "{option} {v}: must be in (0, 1]{hint}"
    );
    Ok(())
}

pub use crate::render::cell::ert::ErtMode;

/// Decides what `--ert THRESHOLD` means: (0, 1) on, 1 off, else an error.
pub fn ert_mode(threshold: f32) -> anyhow::Result<ErtMode> {
    unit_interval(
        "--ert",
        threshold,
        " (a threshold below 1 turns early ray termination on, e.g. 0.9 or 0.99; 1 turns it off)",
    )?;
    Ok(ErtMode::of_threshold(threshold))
}

/// `option` (given) only works when `condition` holds; otherwise an error
/// that says how to turn it on (`how`).
pub fn needs(option: &str, given: bool, condition: bool, how: &str) -> anyhow::Result<()> {
    anyhow::ensure!(!given || condition, "{option} needs {how}");
    Ok(())
}

/// Largest image in pixels: pixel indices are 32-bit in the per-pixel lists.
pub const MAX_PIXELS: u64 = u32::MAX as u64;

/// `--width`/`--height` overrides: both positive, at most [`MAX_PIXELS`].
pub fn image_size(width: Option<u32>, height: Option<u32>) -> anyhow::Result<()> {
    if let (Some(w), Some(h)) = (width, height) {
        anyhow::ensure!(
            w > 0 && h > 0,
            "--width {w} --height {h}: both must be at least 1"
        );
        let n = w as u64 * h as u64;
        anyhow::ensure!(
            n <= MAX_PIXELS,
            "--width {w} --height {h}: {n} pixels is more than pvrsim supports ({MAX_PIXELS})"
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ert_mode_decides_on_off_and_errors() {
        assert_eq!(ert_mode(0.9).unwrap(), ErtMode::On(0.9));
        assert_eq!(ert_mode(1.0).unwrap(), ErtMode::Off);
        for bad in [0.0, -0.5, 1.5, f32::NAN, f32::INFINITY] {
            let e = ert_mode(bad).unwrap_err().to_string();
            assert!(e.contains("--ert") && e.contains("(0, 1]"), "{e}");
        }
    }

    #[test]
    fn needs_names_the_missing_option() {
        assert!(needs("--share", false, false, "ERT").is_ok());
        assert!(needs("--share", true, true, "ERT").is_ok());
        let e = needs("--share", true, false, "--ert < 1").unwrap_err();
        assert_eq!(e.to_string(), "--share needs --ert < 1");
    }

    #[test]
    fn image_size_limits() {
        assert!(image_size(Some(100), Some(100)).is_ok());
        assert!(image_size(Some(0), Some(100)).is_err());
        assert!(image_size(Some(65536), Some(65536)).is_err());
        assert!(at_least("--tile", 0u32, 1).is_err());
    }
}
