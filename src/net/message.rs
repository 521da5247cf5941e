//! Typed messages: ranks, message kinds, envelopes and the size-limited
//! bincode codec.
//!
//! A message travels as an [`Envelope`]: who sent it, to whom, its
//! [`MessageKind`] (for accounting and dispatch) and an opaque payload. The
//! payload is the bincode encoding of a typed value; a type implementing
//! [`Message`] names its kind once, so [`Codec::encode`] and
//! [`Envelope::decode`] cannot mix kinds up.
//!
//! # Encoding
//!
//! bincode 1.x with fixed-width little-endian integers: a `u32` takes 4 bytes
//! and a `Vec<f32>` of n values takes 8 + 4n bytes, the size the papers' MPI
//! code would put on the wire for the same arrays, so byte counts in the
//! simulator match what the cluster sent. (bincode 1.x is chosen over 2.x
//! because its size limit is a run-time value, `Options::with_limit(u64)`;
//! 2.x takes the limit as a const generic, so a user-configured maximum
//! would be impossible.)
//!
//! # Untrusted input
//!
//! A payload longer than [`Codec::max_message_bytes`] (default
//! [`DEFAULT_MAX_MESSAGE_BYTES`] = 256 MiB) is refused before decoding, and a
//! frame header announcing more is refused before its body is read. Inside a
//! payload, bincode checks every byte-buffer length prefix against the bytes
//! actually left before allocating, and preallocates sequences only up to a
//! small fixed bound, so a forged `len = 2^60` is a "truncated" error, not an
//! allocation; encoding is bounded by the same limit. Trailing bytes are
//! rejected. Every failure is a [`NetError`] that names the kind.
//!
//! # Frames
//!
//! For byte-stream transports (TCP), [`Codec::encode_frame`] prefixes the
//! payload with a fixed [`FRAME_HEADER_BYTES`]-byte header:
//!
//! ```text
//! offset 0   u32 LE  from
//! offset 4   u32 LE  to
//! offset 8   u8      kind (MessageKind::code)
//! offset 9   u64 LE  payload length n   (checked against the limit)
//! offset 17  n bytes payload
//! ```

use bincode::Options;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::error::{NetError, NetResult};
pub use super::names::{MessageKind, NodeId};

/// Default upper bound on one message's payload: 256 MiB. The largest
/// legitimate message in the papers' setting is a full-screen image or a
/// work grant of all cells of one node (307,565 tets × (4 indices + 4
/// vertices × 4 floats) ≈ 25 MB), an order of magnitude below this.
pub const DEFAULT_MAX_MESSAGE_BYTES: u64 = 256 * 1024 * 1024;

/// Size of a frame header written by [`Codec::encode_frame`].
pub const FRAME_HEADER_BYTES: usize = 17;

/// A typed message: a serde type that knows its [`MessageKind`].
///
/// ```
/// use pvrsim::net::{Codec, Message, MessageKind};
/// #[derive(serde::Serialize, serde::Deserialize, Debug, PartialEq)]
/// struct Steal { cells: u32 }
/// impl Message for Steal { const KIND: MessageKind = MessageKind::WorkRequest; }
///
/// let codec = Codec::default();
/// let bytes = codec.encode(&Steal { cells: 7 }).unwrap();
/// assert_eq!(codec.decode::<Steal>(&bytes).unwrap(), Steal { cells: 7 });
/// ```
pub trait Message: Serialize + DeserializeOwned {
    /// The kind every value of this type is sent as.
    const KIND: MessageKind;
}

/// One message in flight: sender, receiver, kind and encoded payload.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Envelope {
    /// The sending rank.
    pub from: NodeId,
    /// The receiving rank.
    pub to: NodeId,
    /// What the payload is.
    pub kind: MessageKind,
    /// The bincode encoding of the message (see [`Codec`]).
    pub payload: Vec<u8>,
}

impl Envelope {
    /// Decodes the payload as `M`, checking that the envelope's kind is
    /// `M::KIND`.
    pub fn decode<M: Message>(&self, codec: &Codec) -> NetResult<M> {
        if self.kind != M::KIND {
            return Err(NetError::WrongKind {
                expected: M::KIND,
                found: self.kind,
            });
        }
        codec.decode_as(self.kind, &self.payload)
    }

    /// Payload size in bytes, as counted by [`crate::net::TrafficStats`].
    pub fn len(&self) -> u64 {
        self.payload.len() as u64
    }

    /// True for an empty payload.
    pub fn is_empty(&self) -> bool {
        self.payload.is_empty()
    }
}

/// Encoder/decoder with a maximum message size. Cheap to copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Codec {
    /// Largest payload (bytes) that will be encoded or decoded.
    pub max_message_bytes: u64,
}

impl Default for Codec {
    fn default() -> Self {
        Codec {
            max_message_bytes: DEFAULT_MAX_MESSAGE_BYTES,
        }
    }
}

impl Codec {
    /// A codec with the given payload limit in bytes.
    pub fn with_limit(max_message_bytes: u64) -> Self {
        Codec { max_message_bytes }
    }

    fn options(&self) -> impl Options {
        unbounded().with_limit(self.max_message_bytes)
    }

    /// Encoded size of `value` in bytes (no limit applied).
    pub fn encoded_size<T: Serialize + ?Sized>(&self, value: &T) -> u64 {
        unbounded().serialized_size(value).unwrap_or(u64::MAX)
    }

    /// Encodes a typed message.
    pub fn encode<M: Message>(&self, msg: &M) -> NetResult<Vec<u8>> {
        self.encode_as(M::KIND, msg)
    }

    /// Decodes a typed message from a payload.
    pub fn decode<M: Message>(&self, payload: &[u8]) -> NetResult<M> {
        self.decode_as(M::KIND, payload)
    }

    /// Encodes any serde value, labelled `kind` in errors.
    pub fn encode_as<T: Serialize + ?Sized>(
        &self,
        kind: MessageKind,
        value: &T,
    ) -> NetResult<Vec<u8>> {
        self.options().serialize(value).map_err(|e| match *e {
            bincode::ErrorKind::SizeLimit => NetError::TooLarge {
                kind,
                size: self.encoded_size(value),
                limit: self.max_message_bytes,
            },
            other => NetError::Encode {
                kind,
                msg: other.to_string(),
            },
        })
    }

    /// Decodes any serde value, labelled `kind` in errors. Fails (never
    /// panics) on truncated input, trailing bytes, invalid values and length
    /// prefixes beyond the limit.
    pub fn decode_as<T: DeserializeOwned>(
        &self,
        kind: MessageKind,
        payload: &[u8],
    ) -> NetResult<T> {
        if payload.len() as u64 > self.max_message_bytes {
            return Err(NetError::TooLarge {
                kind,
                size: payload.len() as u64,
                limit: self.max_message_bytes,
            });
        }
        self.options()
            .deserialize(payload)
            .map_err(|e| NetError::Decode {
                kind,
                msg: describe(&e, payload.len()),
            })
    }

    /// Writes an envelope as a frame (header + payload) for a byte stream.
    pub fn encode_frame(&self, env: &Envelope) -> NetResult<Vec<u8>> {
        let n = env.payload.len() as u64;
        if n > self.max_message_bytes {
            return Err(NetError::TooLarge {
                kind: env.kind,
                size: n,
                limit: self.max_message_bytes,
            });
        }
        let mut out = Vec::with_capacity(FRAME_HEADER_BYTES + env.payload.len());
        out.extend_from_slice(&env.from.0.to_le_bytes());
        out.extend_from_slice(&env.to.0.to_le_bytes());
        out.push(env.kind.code());
        out.extend_from_slice(&n.to_le_bytes());
        out.extend_from_slice(&env.payload);
        Ok(out)
    }

    /// Parses a frame header: `(from, to, kind, payload length)`. The length
    /// is checked against the limit, so a stream reader may allocate it.
    pub fn decode_frame_header(
        &self,
        header: &[u8; FRAME_HEADER_BYTES],
    ) -> NetResult<(NodeId, NodeId, MessageKind, u64)> {
        let u32_at =
            |o: usize| u32::from_le_bytes([header[o], header[o + 1], header[o + 2], header[o + 3]]);
        let from = NodeId(u32_at(0));
        let to = NodeId(u32_at(4));
        let kind = MessageKind::from_code(header[8])
            .ok_or_else(|| NetError::Frame(format!("unknown message kind code {}", header[8])))?;
        let mut len = [0u8; 8];
        len.copy_from_slice(&header[9..17]);
        let len = u64::from_le_bytes(len);
        if len > self.max_message_bytes {
            return Err(NetError::TooLarge {
                kind,
                size: len,
                limit: self.max_message_bytes,
            });
        }
        Ok((from, to, kind, len))
    }

    /// Parses a whole frame (header + exactly the announced payload).
    pub fn decode_frame(&self, frame: &[u8]) -> NetResult<Envelope> {
        let header: &[u8; FRAME_HEADER_BYTES] = frame
            .get(..FRAME_HEADER_BYTES)
            .and_then(|h| h.try_into().ok())
            .ok_or_else(|| {
                NetError::Frame(format!(
                    "{} bytes is shorter than the {FRAME_HEADER_BYTES}-byte header",
                    frame.len()
                ))
            })?;
        let (from, to, kind, len) = self.decode_frame_header(header)?;
        let body = &frame[FRAME_HEADER_BYTES..];
        if body.len() as u64 != len {
            return Err(NetError::Decode {
                kind,
                msg: format!(
                    "frame announces {len} payload bytes but carries {}",
                    body.len()
                ),
            });
        }
        Ok(Envelope {
            from,
            to,
            kind,
            payload: body.to_vec(),
        })
    }
}

/// The wire format without a size limit.
fn unbounded() -> impl Options {
    bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .with_little_endian()
        .reject_trailing_bytes()
}

/// Human-readable cause of a bincode failure.
fn describe(e: &bincode::ErrorKind, len: usize) -> String {
    match e {
        bincode::ErrorKind::SizeLimit => {
            "a length prefix exceeds the message size limit (corrupt or hostile input)".into()
        }
        bincode::ErrorKind::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            format!("truncated: the payload ends early ({len} bytes)")
        }
        other => other.to_string(),
    }
}
