//! Link frames on a byte stream, after the handshake.
//!
//! ```text
//! tag u8 = 0  DATA       then the 17-byte `Codec` frame header and the payload
//!                         (from u32, to u32, kind u8, len u64; len <= limit)
//! tag u8 = 1  HEARTBEAT  nothing else ("I am alive"; sent when a link is idle)
//! tag u8 = 2  GOODBYE    nothing else (a clean end, told apart from a death)
//! ```
//!
//! The payload length is checked against the configured limit by
//! [`Codec::decode_frame_header`] **before** the payload buffer is
//! allocated, so a forged length of 2^60 is an error, not an allocation.
//! Any other tag is a malformed frame. The same parser runs over a blocking
//! reader ([`read_frame`]: the proptest and the fuzz target) and over a
//! tokio stream ([`read_frame_async`]: the transport).

use std::io::Read;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncReadExt};

use crate::net::error::{NetError, NetResult};
use crate::net::message::{Codec, Envelope, FRAME_HEADER_BYTES};

/// Tag of a data frame.
pub const TAG_DATA: u8 = 0;
/// Tag of a heartbeat.
pub const TAG_HEARTBEAT: u8 = 1;
/// Tag of a goodbye.
pub const TAG_GOODBYE: u8 = 2;

/// One link frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkFrame {
    /// A message.
    Data(Envelope),
    /// The peer is alive.
    Heartbeat,
    /// The peer ends the connection cleanly.
    Goodbye,
}

/// Bytes of a data frame on the wire for a payload of `n` bytes.
pub fn data_frame_bytes(n: u64) -> u64 {
    1 + FRAME_HEADER_BYTES as u64 + n
}

/// Encodes a frame (the payload limit of `codec` applies).
pub fn encode_frame(codec: &Codec, frame: &LinkFrame) -> NetResult<Vec<u8>> {
    match frame {
        LinkFrame::Data(env) => {
            let body = codec.encode_frame(env)?;
            let mut out = Vec::with_capacity(1 + body.len());
            out.push(TAG_DATA);
            out.extend_from_slice(&body);
            Ok(out)
        }
        LinkFrame::Heartbeat => Ok(vec![TAG_HEARTBEAT]),
        LinkFrame::Goodbye => Ok(vec![TAG_GOODBYE]),
    }
}

fn unknown_tag(tag: u8) -> NetError {
    NetError::Frame(format!(
        "unknown link frame tag {tag} (expected 0 data, 1 heartbeat, 2 goodbye)"
    ))
}

fn io_err(what: &str, e: std::io::Error) -> NetError {
    if e.kind() == std::io::ErrorKind::UnexpectedEof {
        NetError::Frame(format!("the stream ends inside a frame's {what}"))
    } else {
        NetError::Frame(format!("reading a frame's {what}: {e}"))
    }
}

/// Reads one frame from a blocking reader. `Ok(None)`: the stream ended
/// cleanly between frames (no goodbye: the caller decides what that means).
pub fn read_frame<R: Read>(r: &mut R, codec: &Codec) -> NetResult<Option<LinkFrame>> {
    let mut tag = [0u8; 1];
    match r.read(&mut tag) {
        Ok(0) => return Ok(None),
        Ok(_) => {}
        Err(e) => return Err(io_err("tag", e)),
    }
    match tag[0] {
        TAG_HEARTBEAT => Ok(Some(LinkFrame::Heartbeat)),
        TAG_GOODBYE => Ok(Some(LinkFrame::Goodbye)),
        TAG_DATA => {
            let mut h = [0u8; FRAME_HEADER_BYTES];
            r.read_exact(&mut h).map_err(|e| io_err("header", e))?;
            let (from, to, kind, len) = codec.decode_frame_header(&h)?;
            // `len` <= the limit here, so this allocation is bounded.
            let mut payload = vec![0u8; len as usize];
            r.read_exact(&mut payload)
                .map_err(|e| io_err("payload", e))?;
            Ok(Some(LinkFrame::Data(Envelope {
                from,
                to,
                kind,
                payload,
            })))
        }
        t => Err(unknown_tag(t)),
    }
}

/// Reads one frame from a tokio stream; same format and checks as
/// [`read_frame`]. With `deadline`, every step (the tag, the header, each
/// 64 KiB of payload) must arrive within it: a peer that stops sending
/// (stalled, stopped, or a half-written frame) is an error after
/// `deadline`, whatever the frame's size.
pub async fn read_frame_async<R: AsyncRead + Unpin>(
    r: &mut R,
    codec: &Codec,
    deadline: Option<Duration>,
) -> NetResult<Option<LinkFrame>> {
    let mut tag = [0u8; 1];
    match within(deadline, "the next frame", r.read(&mut tag)).await? {
        Ok(0) => return Ok(None),
        Ok(_) => {}
        Err(e) => return Err(io_err("tag", e)),
    }
    match tag[0] {
        TAG_HEARTBEAT => Ok(Some(LinkFrame::Heartbeat)),
        TAG_GOODBYE => Ok(Some(LinkFrame::Goodbye)),
        TAG_DATA => {
            let mut h = [0u8; FRAME_HEADER_BYTES];
            within(deadline, "a frame header", r.read_exact(&mut h))
                .await?
                .map_err(|e| io_err("header", e))?;
            let (from, to, kind, len) = codec.decode_frame_header(&h)?;
            // `len` <= the limit here, so this allocation is bounded.
            let mut payload = vec![0u8; len as usize];
            for chunk in payload.chunks_mut(64 * 1024) {
                within(deadline, "a frame's payload", r.read_exact(chunk))
                    .await?
                    .map_err(|e| io_err("payload", e))?;
            }
            Ok(Some(LinkFrame::Data(Envelope {
                from,
                to,
                kind,
                payload,
            })))
        }
        t => Err(unknown_tag(t)),
    }
}

/// Late deadline timers seen by this process: how many, and the longest
/// delay past the deadline in microseconds (see [`late_wakeups`]).
static LATE: AtomicU64 = AtomicU64::new(0);
static LATE_MAX_US: AtomicU64 = AtomicU64::new(0);

/// How often a link's deadline timer fired much later than it was due
/// (more than half a deadline late), and the longest such delay in
/// seconds: this process itself was not running (stopped with SIGSTOP,
/// starved of CPU, a suspended VM), so the silence was not the peer's.
/// A caller compares two readings to learn whether it happened meanwhile.
pub fn late_wakeups() -> (u64, f64) {
    (
        LATE.load(Ordering::Relaxed),
        LATE_MAX_US.load(Ordering::Relaxed) as f64 * 1e-6,
    )
}

/// `f` within `deadline` of silence. A deadline timer that fires more
/// than half a deadline late means that this process was not scheduled
/// (not that the peer was silent): the wait then starts again, with the
/// same future (nothing read is lost), and the bytes that arrived
/// meanwhile are read at once.
async fn within<F: std::future::Future>(
    deadline: Option<Duration>,
    what: &str,
    f: F,
) -> NetResult<F::Output> {
    let Some(d) = deadline else {
        return Ok(f.await);
    };
    let mut f = std::pin::pin!(f);
    loop {
        let start = std::time::Instant::now();
        match tokio::time::timeout(d, &mut f).await {
            Ok(x) => return Ok(x),
            Err(_) => {
                let late = start.elapsed().saturating_sub(d);
                if late > d / 2 {
                    LATE.fetch_add(1, Ordering::Relaxed);
                    LATE_MAX_US.fetch_max(late.as_micros() as u64, Ordering::Relaxed);
                    continue;
                }
                return Err(NetError::Io {
                    what: format!(
                        "nothing received for {:.1} s while waiting for {what}",
                        d.as_secs_f64()
                    ),
                    msg: "no heartbeat: the peer is stalled (e.g. SIGSTOP), hung, or the network is down"
                        .into(),
                });
            }
        }
    }
}

/// Decodes every frame in `bytes` (for the fuzz target and the proptest):
/// the frames up to the first error, and the error if any. A clean end is
/// only at a frame boundary.
pub fn decode_all(bytes: &[u8], codec: &Codec) -> (Vec<LinkFrame>, Option<NetError>) {
    let mut r = bytes;
    let mut out = Vec::new();
    loop {
        match read_frame(&mut r, codec) {
            Ok(Some(f)) => out.push(f),
            Ok(None) => return (out, None),
            Err(e) => return (out, Some(e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::net::message::{MessageKind, NodeId};
    use proptest::prelude::*;

    fn env(from: u32, to: u32, kind: u8, payload: Vec<u8>) -> Envelope {
        Envelope {
            from: NodeId(from),
            to: NodeId(to),
            kind: MessageKind::from_code(kind % 8).unwrap(),
            payload,
        }
    }

    /// This process not scheduled (the runtime's only thread blocked, as
    /// under SIGSTOP) for four of a link's deadlines; the peer's next
    /// heartbeat comes just after it runs again: the late timer does not
    /// declare the peer silent (without the check it would), the wait
    /// starts again, the heartbeat is read, and the late wake-up is counted.
    #[test]
    fn a_late_deadline_timer_is_not_the_peers_silence() {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap();
        let peer = std::thread::spawn(move || {
            let (mut s, _) = l.accept().unwrap();
            std::thread::sleep(Duration::from_millis(880));
            std::io::Write::write_all(&mut s, &[TAG_HEARTBEAT]).unwrap();
            std::thread::sleep(Duration::from_millis(500));
        });
        let (late0, _) = late_wakeups();
        let got = rt.block_on(async {
            let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
            // Blocks the runtime's only thread for four deadlines, from
            // just after the read starts.
            tokio::spawn(async {
                tokio::time::sleep(Duration::from_millis(10)).await;
                std::thread::sleep(Duration::from_millis(800));
            });
            read_frame_async(&mut s, &Codec::default(), Some(Duration::from_millis(200))).await
        });
        peer.join().unwrap();
        assert_eq!(got.unwrap(), Some(LinkFrame::Heartbeat));
        assert!(late_wakeups().0 > late0);
    }

    #[test]
    fn forged_length_is_an_error_before_allocation() {
        let codec = Codec::with_limit(1 << 20);
        let mut b = vec![TAG_DATA];
        b.extend_from_slice(&0u32.to_le_bytes());
        b.extend_from_slice(&1u32.to_le_bytes());
        b.push(0);
        b.extend_from_slice(&(1u64 << 60).to_le_bytes());
        let (frames, err) = decode_all(&b, &codec);
        assert!(frames.is_empty());
        let e = err.expect("an error").to_string();
        assert!(e.contains("exceeds the limit"), "{e}");
    }

    #[test]
    fn unknown_tag_and_truncation_are_errors() {
        let codec = Codec::default();
        let (_, e) = decode_all(&[7], &codec);
        assert!(e.unwrap().to_string().contains("unknown link frame tag 7"));
        let (_, e) = decode_all(&[TAG_DATA, 1, 2], &codec);
        assert!(e
            .unwrap()
            .to_string()
            .contains("ends inside a frame's header"));
    }

    proptest! {
        #[test]
        fn frames_round_trip(
            msgs in proptest::collection::vec(
                (0u32..9, 0u32..9, 0u8..8, proptest::collection::vec(any::<u8>(), 0..64), 0u8..3),
                0..12)
        ) {
            let codec = Codec::with_limit(1024);
            let frames: Vec<LinkFrame> = msgs
                .into_iter()
                .map(|(f, t, k, p, which)| match which {
                    0 => LinkFrame::Data(env(f, t, k, p)),
                    1 => LinkFrame::Heartbeat,
                    _ => LinkFrame::Goodbye,
                })
                .collect();
            let mut bytes = Vec::new();
            for f in &frames {
                bytes.extend(encode_frame(&codec, f).unwrap());
            }
            let (back, err) = decode_all(&bytes, &codec);
            prop_assert!(err.is_none());
            prop_assert_eq!(back, frames);
        }

        #[test]
        fn arbitrary_bytes_never_panic_and_respect_the_limit(
            bytes in proptest::collection::vec(any::<u8>(), 0..256)
        ) {
            let codec = Codec::with_limit(32);
            let (frames, _) = decode_all(&bytes, &codec);
            for f in frames {
                if let LinkFrame::Data(e) = f {
                    prop_assert!(e.payload.len() <= 32);
                }
            }
        }

        #[test]
        fn every_truncation_of_a_valid_stream_is_a_clean_error(
            payload in proptest::collection::vec(any::<u8>(), 0..40),
            cut in 0usize..80
        ) {
            let codec = Codec::default();
            let bytes = encode_frame(&codec, &LinkFrame::Data(env(1, 2, 3, payload))).unwrap();
            let cut = cut.min(bytes.len());
            let (frames, err) = decode_all(&bytes[..cut], &codec);
            if cut == 0 {
                prop_assert!(frames.is_empty() && err.is_none());
            } else if cut < bytes.len() {
                prop_assert!(frames.is_empty() && err.is_some());
            } else {
                prop_assert_eq!(frames.len(), 1);
            }
        }
    }
}
