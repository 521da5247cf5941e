//! Typed messages on a bare authenticated stream, before a [`super::TcpTransport`]
//! owns it (session set-up: the coordinator's set-up message, the cache
//! answer, the cells). Same link frames as the transport.

use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite, AsyncWriteExt};

use super::frame::{encode_frame, read_frame_async, LinkFrame};
use crate::net::error::{NetError, NetResult};
use crate::net::message::{Codec, Envelope, Message, NodeId};

/// Writes `msg` as a data frame from `from` to `to`.
pub async fn write_msg<S: AsyncWrite + Unpin, M: Message>(
    s: &mut S,
    codec: &Codec,
    from: NodeId,
    to: NodeId,
    msg: &M,
    peer: &str,
) -> NetResult<()> {
    let env = Envelope {
        from,
        to,
        kind: M::KIND,
        payload: codec.encode(msg)?,
    };
    let f = encode_frame(codec, &LinkFrame::Data(env))?;
    let io = |e: std::io::Error| NetError::PeerLost {
        peer: peer.to_string(),
        reason: format!("sending a {}: {e}", M::KIND),
    };
    s.write_all(&f).await.map_err(io)?;
    s.flush().await.map_err(io)
}

/// [`write_msg`] with a progress deadline: every 64 KiB of the frame must
/// be written within `deadline` (a peer that stopped reading, or a link
/// slowed to a crawl, is an error naming `peer`, not a hang).
pub async fn write_msg_within<S: AsyncWrite + Unpin, M: Message>(
    s: &mut S,
    codec: &Codec,
    from: NodeId,
    to: NodeId,
    msg: &M,
    peer: &str,
    deadline: Duration,
) -> NetResult<()> {
    let env = Envelope {
        from,
        to,
        kind: M::KIND,
        payload: codec.encode(msg)?,
    };
    let f = encode_frame(codec, &LinkFrame::Data(env))?;
    let lost = |reason: String| NetError::PeerLost {
        peer: peer.to_string(),
        reason,
    };
    for chunk in f.chunks(64 * 1024) {
        match tokio::time::timeout(deadline, s.write_all(chunk)).await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(lost(format!("sending a {}: {e}", M::KIND))),
            Err(_) => {
                return Err(lost(format!(
                    "sending a {}: no progress for {:.1} s (the peer stopped reading, or the link crawls)",
                    M::KIND,
                    deadline.as_secs_f64()
                )))
            }
        }
    }
    match tokio::time::timeout(deadline, s.flush()).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(e)) => Err(lost(format!("sending a {}: {e}", M::KIND))),
        Err(_) => Err(lost(format!("sending a {}: the flush stalled", M::KIND))),
    }
}

/// Reads the next data frame (skipping heartbeats) and decodes it as `M`;
/// a goodbye, an end of stream or `deadline` of silence is an error naming
/// `peer`.
pub async fn read_msg<S: AsyncRead + Unpin, M: Message>(
    s: &mut S,
    codec: &Codec,
    deadline: Duration,
    peer: &str,
) -> NetResult<M> {
    let lost = |reason: String| NetError::PeerLost {
        peer: peer.to_string(),
        reason,
    };
    loop {
        match read_frame_async(s, codec, Some(deadline)).await {
            Ok(Some(LinkFrame::Data(env))) => return env.decode(codec),
            Ok(Some(LinkFrame::Heartbeat)) => continue,
            Ok(Some(LinkFrame::Goodbye)) => return Err(lost("said Goodbye during set-up".into())),
            Ok(None) => return Err(lost("closed the connection during set-up".into())),
            Err(e) => return Err(lost(e.to_string())),
        }
    }
}
