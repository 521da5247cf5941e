//! The compositing strategy as a typed choice ([`Compositing`]): parsed
//! once (from `--compositor`/`--radix-k`, a job file, a set-up message),
//! carried by configurations and wire set-ups, and built into a
//! [`Strategy`] without any way to fail.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::{BinarySwap, DirectSend, Master, RadixK, Strategy};

/// Radix-k's target group size `k`, checked: a whole number from
/// [`GroupSize::MIN`] to [`GroupSize::MAX`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GroupSize(usize);

impl GroupSize {
    /// Smallest `k`.
    pub const MIN: usize = 2;
    /// Largest `k`.
    pub const MAX: usize = 4096;

    /// `k`, or why it is not a group size.
    pub fn new(k: usize) -> Result<Self, String> {
        if (Self::MIN..=Self::MAX).contains(&k) {
            Ok(GroupSize(k))
        } else {
            Err(Self::refusal(&k.to_string()))
        }
    }

    /// The size.
    pub fn get(self) -> usize {
        self.0
    }

    fn refusal(k: &str) -> String {
        format!(
            "radix-k's k must be a whole number from {} to {} (got `{k}`)",
            Self::MIN,
            Self::MAX
        )
    }
}

impl FromStr for GroupSize {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        s.trim()
            .parse::<usize>()
            .map_err(|_| Self::refusal(s))
            .and_then(Self::new)
    }
}

/// A compositing strategy as chosen: its name and, for radix-k, the group
/// size when one was given. The text form is the one `--compositor` takes
/// and reports show: `binary-swap`, `direct-send`, `master`, `radix-k`
/// (IceT's default k) or `radix-k:K` (aliases `bswap`, `direct`, `radixk`
/// parse to the full names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Compositing {
    /// Direct send (`direct-send`).
    DirectSend,
    /// Binary swap (`binary-swap`, the default).
    #[default]
    BinarySwap,
    /// Everything to rank 0 (`master`).
    Master,
    /// Radix-k (`radix-k`, `radix-k:K`), with `k` if given.
    RadixK(Option<GroupSize>),
}

impl Compositing {
    /// The strategy's name without parameters (`radix-k` for any k).
    pub fn name(self) -> &'static str {
        match self {
            Compositing::DirectSend => "direct-send",
            Compositing::BinarySwap => "binary-swap",
            Compositing::Master => "master",
            Compositing::RadixK(_) => "radix-k",
        }
    }

    /// The strategy.
    pub fn build(self) -> Box<dyn Strategy> {
        match self {
            Compositing::DirectSend => Box::new(DirectSend::default()),
            Compositing::BinarySwap => Box::new(BinarySwap),
            Compositing::Master => Box::new(Master),
            Compositing::RadixK(None) => Box::new(RadixK::default()),
            Compositing::RadixK(Some(k)) => Box::new(RadixK { k: k.get() }),
        }
    }

    /// This choice with radix-k's group size `k` (`--radix-k`): only
    /// radix-k takes one, and only once (`radix-k:K` with `--radix-k` is
    /// refused rather than one of them ignored).
    pub fn with_group_size(self, k: GroupSize) -> Result<Self, String> {
        match self {
            Compositing::RadixK(None) => Ok(Compositing::RadixK(Some(k))),
            other => Err(format!(
                "--radix-k {} sets radix-k's group size; it needs --compositor radix-k \
                 (got --compositor {other})",
                k.get()
            )),
        }
    }
}

impl fmt::Display for Compositing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Compositing::RadixK(Some(k)) => write!(f, "radix-k:{}", k.get()),
            c => f.write_str(c.name()),
        }
    }
}

impl FromStr for Compositing {
    type Err = String;
    fn from_str(name: &str) -> Result<Self, String> {
        match name {
            "direct-send" | "direct" => Ok(Compositing::DirectSend),
            "binary-swap" | "bswap" => Ok(Compositing::BinarySwap),
            "master" => Ok(Compositing::Master),
            "radix-k" | "radixk" => Ok(Compositing::RadixK(None)),
            _ if name.starts_with("radix-k:") => {
                let k = &name["radix-k:".len()..];
                let k = k
                    .parse::<GroupSize>()
                    .map_err(|e| format!("`{name}`: {e}"))?;
                Ok(Compositing::RadixK(Some(k)))
            }
            _ => Err(format!(
                "unknown compositing strategy `{name}`; choose one of: {}",
                super::list()
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }
}

/// The text form (as [`fmt::Display`] writes it): the bytes of set-up
/// messages are those of the name.
impl Serialize for Compositing {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

/// Parsed from the text form; an unknown name is a decoding error.
impl<'de> Deserialize<'de> for Compositing {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_ones_are_refused() {
        for name in [
            "direct-send",
            "binary-swap",
            "master",
            "radix-k",
            "radix-k:3",
        ] {
            let c: Compositing = name.parse().unwrap();
            assert_eq!(c.to_string(), name);
            let bytes = bincode::serialize(&c).unwrap();
            assert_eq!(bytes, bincode::serialize(&name.to_string()).unwrap());
            assert_eq!(bincode::deserialize::<Compositing>(&bytes).unwrap(), c);
        }
        assert_eq!("bswap".parse(), Ok(Compositing::BinarySwap));
        assert_eq!(Compositing::RadixK(None).build().label(), "radix-k:8");
        let k = GroupSize::new(4).unwrap();
        assert_eq!(
            Compositing::RadixK(None)
                .with_group_size(k)
                .unwrap()
                .build()
                .label(),
            "radix-k:4"
        );
        let e = Compositing::Master.with_group_size(k).unwrap_err();
        assert!(e.contains("--compositor master"), "{e}");
        assert!("radix-k:4"
            .parse::<Compositing>()
            .unwrap()
            .with_group_size(k)
            .is_err());
        let bad = bincode::serialize(&"nope".to_string()).unwrap();
        assert!(bincode::deserialize::<Compositing>(&bad).is_err());
        assert!("1"
            .parse::<GroupSize>()
            .unwrap_err()
            .contains("from 2 to 4096"));
    }
}
