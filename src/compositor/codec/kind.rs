//! The codecs as typed choices: [`ListCodecKind`] for segment lists and
//! pixels (mesh frames), [`LayerCodecKind`] for RGBA layers (grid frames).
//! Parsed once (a name, a set-up message), carried by configurations and
//! wire set-ups, built into a codec without any way to fail. Both travel
//! as their names (serde and [`std::fmt::Display`]), so set-up messages
//! and reports hold the same text as before the choice was typed.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::layers::LayerCodec;
use super::Codec;
use crate::compositor::layer_types::Depth;

/// A list/pixel codec (`--codec` of a mesh frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ListCodecKind {
    /// No compression (`raw`).
    Raw,
    /// Empty runs collapsed (`rle`, the default).
    #[default]
    Rle,
}

impl ListCodecKind {
    /// Every list codec.
    pub const ALL: [ListCodecKind; 2] = [ListCodecKind::Raw, ListCodecKind::Rle];

    /// The codec's name.
    pub fn name(self) -> &'static str {
        match self {
            ListCodecKind::Raw => "raw",
            ListCodecKind::Rle => "rle",
        }
    }

    /// The codec.
    pub fn build(self) -> Box<dyn Codec> {
        match self {
            ListCodecKind::Raw => Box::new(super::Raw),
            ListCodecKind::Rle => Box::new(super::Rle),
        }
    }
}

impl FromStr for ListCodecKind {
    type Err = String;
    fn from_str(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|c| c.name() == name)
            .ok_or_else(|| format!("unknown codec `{name}`; choose one of: raw, rle"))
    }
}

/// An RGBA layer codec (`--codec` of a grid frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum LayerCodecKind {
    /// RGBA8 (`raw`).
    Raw,
    /// The paper's RLE of RGBA8 (`rle-paper`).
    RlePaper,
    /// IceT's active-pixel runs of RGBA8 (`sparse`).
    Sparse,
    /// RGBA16 (`raw16`).
    Raw16,
    /// The paper's RLE at 16 bits (`rle16`, the default).
    #[default]
    Rle16,
    /// Active-pixel runs of RGBA16 (`sparse16`).
    Sparse16,
}

impl LayerCodecKind {
    /// The layer codec grid runs use unless told otherwise.
    pub const DEFAULT: LayerCodecKind = LayerCodecKind::Rle16;

    /// Every layer codec, in [`super::layers::list`]'s order.
    pub const ALL: [LayerCodecKind; 6] = [
        LayerCodecKind::Raw,
        LayerCodecKind::RlePaper,
        LayerCodecKind::Sparse,
        LayerCodecKind::Raw16,
        LayerCodecKind::Rle16,
        LayerCodecKind::Sparse16,
    ];

    /// The codec's name.
    pub fn name(self) -> &'static str {
        match self {
            LayerCodecKind::Raw => "raw",
            LayerCodecKind::RlePaper => "rle-paper",
            LayerCodecKind::Sparse => "sparse",
            LayerCodecKind::Raw16 => "raw16",
            LayerCodecKind::Rle16 => "rle16",
            LayerCodecKind::Sparse16 => "sparse16",
        }
    }

    /// The codec.
    pub fn build(self) -> Box<dyn LayerCodec> {
        use super::layers::{Raw, Rle, Sparse};
        match self {
            LayerCodecKind::Raw => Box::new(Raw(Depth::U8)),
            LayerCodecKind::RlePaper => Box::new(Rle(Depth::U8)),
            LayerCodecKind::Sparse => Box::new(Sparse(Depth::U8)),
            LayerCodecKind::Raw16 => Box::new(Raw(Depth::U16)),
            LayerCodecKind::Rle16 => Box::new(Rle(Depth::U16)),
            LayerCodecKind::Sparse16 => Box::new(Sparse(Depth::U16)),
        }
    }
}

impl FromStr for LayerCodecKind {
    type Err = String;
    fn from_str(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|c| c.name() == name)
            .ok_or_else(|| {
                format!(
                    "unknown codec `{name}` for RGBA layers (grid scenes); choose one of: {}",
                    Self::ALL.map(|c| c.name()).join(", ")
                )
            })
    }
}

macro_rules! by_name {
    ($t:ty) => {
        impl fmt::Display for $t {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }

        /// The name (the bytes of a set-up message are those of the name).
        impl Serialize for $t {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }

        /// Parsed from the name; an unknown one is a decoding error.
        impl<'de> Deserialize<'de> for $t {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let s = String::deserialize(d)?;
                s.parse().map_err(serde::de::Error::custom)
            }
        }
    };
}

by_name!(ListCodecKind);
by_name!(LayerCodecKind);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_are_their_codecs_and_travel_as_names() {
        for k in ListCodecKind::ALL {
            assert_eq!(k.build().name(), k.name());
            assert_eq!(k.name().parse(), Ok(k));
            let b = bincode::serialize(&k).unwrap();
            assert_eq!(b, bincode::serialize(k.name()).unwrap());
            assert_eq!(bincode::deserialize::<ListCodecKind>(&b).unwrap(), k);
        }
        for k in LayerCodecKind::ALL {
            assert_eq!(k.build().name(), k.name());
            assert_eq!(k.name().parse(), Ok(k));
            let b = bincode::serialize(&k).unwrap();
            assert_eq!(bincode::deserialize::<LayerCodecKind>(&b).unwrap(), k);
        }
        assert_eq!(
            super::super::layers::list()
                .iter()
                .map(|c| c.0)
                .collect::<Vec<_>>(),
            LayerCodecKind::ALL.map(|c| c.name()).to_vec()
        );
        assert!("sparse".parse::<ListCodecKind>().is_err());
        let bad = bincode::serialize("zip").unwrap();
        assert!(bincode::deserialize::<LayerCodecKind>(&bad).is_err());
    }
}
