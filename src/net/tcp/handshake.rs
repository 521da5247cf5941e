//! Connection set-up: preamble and two-way HMAC-SHA256 challenge-response.
//!
//! ```text
//! dialer → listener   HELLO     preamble_d (15 B) | nonce_d (32 B)
//! listener → dialer   CHALLENGE 0x00 | preamble_l (15 B) | nonce_l (32 B) | mac_l (32 B)
//!                     or REFUSE 0x01 | len u8 | reason (len B, UTF-8)
//! dialer → listener   PROOF     mac_d (32 B)
//! listener → dialer   VERDICT   0x00, or REFUSE as above
//!
//! preamble = magic "PVRSIM\r\n" (8 B) | version u16 LE | role u8 | rank u32 LE
//! mac_l = HMAC-SHA256(K, "pvrsim-v1 listener" | HELLO | preamble_l | nonce_l)
//! mac_d = HMAC-SHA256(K, "pvrsim-v1 dialer"   | HELLO | preamble_l | nonce_l | mac_l)
//! ```
//!
//! Each side proves it holds the token `K` over a transcript containing the
//! *other* side's fresh random nonce, so a recorded handshake replayed
//! later fails (the new nonce differs), and the labels keep a MAC of one
//! direction from being reflected as the other. Before authentication every
//! field has a fixed size except the refusal text (at most 255 bytes): the
//! "tiny limit". The caller bounds the whole exchange with a timeout.
//! Authentication only: nothing is encrypted (see
//! docs/running-across-machines.md).

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

use super::auth::{random_bytes, Token, NONCE_BYTES};
use crate::net::error::{NetError, NetResult};

/// First bytes on every connection.
pub const MAGIC: [u8; 8] = *b"PVRSIM\r\n";
/// Protocol version; both ends must speak the same (2: phase 2 worker to
/// worker, the set-up names the compositor).
pub const PROTOCOL_VERSION: u16 = 2;
/// Bytes of a preamble.
pub const PREAMBLE_BYTES: usize = 15;

/// The one refusal text a listener sends (the same for every reason, so an
/// unauthenticated peer learns nothing; the listener logs the reason).
pub const REFUSED: &str = "handshake refused (the listener's log says why)";

const LABEL_LISTENER: &[u8] = b"pvrsim-v1 listener";
const LABEL_DIALER: &[u8] = b"pvrsim-v1 dialer";

/// Who opens a connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The coordinator (runs the manager).
    Coordinator,
    /// A worker (one node).
    Worker,
    /// A calibration probe (`pvrsim calibrate --network`).
    Probe,
}

impl Role {
    fn code(self) -> u8 {
        match self {
            Role::Coordinator => 1,
            Role::Worker => 2,
            Role::Probe => 3,
        }
    }

    fn from_code(c: u8) -> Option<Role> {
        match c {
            1 => Some(Role::Coordinator),
            2 => Some(Role::Worker),
            3 => Some(Role::Probe),
            _ => None,
        }
    }
}

/// What a peer said about itself, after it proved it holds the token.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeerHello {
    /// Its role.
    pub role: Role,
    /// Its rank.
    pub rank: u32,
}

fn preamble(role: Role, rank: u32) -> [u8; PREAMBLE_BYTES] {
    let mut p = [0u8; PREAMBLE_BYTES];
    p[..8].copy_from_slice(&MAGIC);
    p[8..10].copy_from_slice(&PROTOCOL_VERSION.to_le_bytes());
    p[10] = role.code();
    p[11..15].copy_from_slice(&rank.to_le_bytes());
    p
}

fn parse_preamble(p: &[u8; PREAMBLE_BYTES], peer: &str) -> NetResult<PeerHello> {
    let err = |msg: String| NetError::Handshake {
        peer: peer.to_string(),
        msg,
    };
    if p[..8] != MAGIC {
        return Err(err(format!(
            "not a pvrsim peer: the connection starts with {:02x?}, not the magic \"PVRSIM\\r\\n\"",
            &p[..8]
        )));
    }
    let v = u16::from_le_bytes([p[8], p[9]]);
    if v != PROTOCOL_VERSION {
        return Err(err(format!(
            "protocol version {v}, this build speaks {PROTOCOL_VERSION}: run the same pvrsim version everywhere"
        )));
    }
    let role = Role::from_code(p[10]).ok_or_else(|| err(format!("unknown role code {}", p[10])))?;
    Ok(PeerHello {
        role,
        rank: u32::from_le_bytes([p[11], p[12], p[13], p[14]]),
    })
}

fn io(peer: &str, stage: &str, e: std::io::Error) -> NetError {
    let msg = if e.kind() == std::io::ErrorKind::UnexpectedEof {
        format!("the peer closed the connection during {stage}")
    } else {
        format!("{stage}: {e}")
    };
    NetError::Handshake {
        peer: peer.to_string(),
        msg,
    }
}

async fn refuse<S: AsyncWrite + Unpin>(s: &mut S, reason: &str) {
    let r = &reason.as_bytes()[..reason.len().min(255)];
    let mut b = vec![1u8, r.len() as u8];
    b.extend_from_slice(r);
    // Best effort: the peer may already be gone.
    let _ = s.write_all(&b).await;
    let _ = s.flush().await;
}

/// Reads a status byte; on REFUSE reads the (at most 255-byte) reason and
/// returns it as an error.
async fn status<S: AsyncRead + Unpin>(s: &mut S, peer: &str, stage: &str) -> NetResult<()> {
    let st = s.read_u8().await.map_err(|e| io(peer, stage, e))?;
    match st {
        0 => Ok(()),
        1 => {
            let n = s.read_u8().await.map_err(|e| io(peer, stage, e))?;
            let mut r = vec![0u8; usize::from(n)];
            s.read_exact(&mut r).await.map_err(|e| io(peer, stage, e))?;
            Err(NetError::Handshake {
                peer: peer.to_string(),
                msg: format!("refused: {}", String::from_utf8_lossy(&r)),
            })
        }
        x => Err(NetError::Handshake {
            peer: peer.to_string(),
            msg: format!("{stage}: not a pvrsim peer (it answered with byte 0x{x:02x})"),
        }),
    }
}

/// The dialing side. `peer` names the other end in errors.
pub async fn dial<S: AsyncRead + AsyncWrite + Unpin>(
    s: &mut S,
    token: &Token,
    role: Role,
    rank: u32,
    peer: &str,
) -> NetResult<PeerHello> {
    let nonce_d = random_bytes::<NONCE_BYTES>()?;
    let mut hello = preamble(role, rank).to_vec();
    hello.extend_from_slice(&nonce_d);
    s.write_all(&hello)
        .await
        .map_err(|e| io(peer, "sending the preamble", e))?;
    s.flush()
        .await
        .map_err(|e| io(peer, "sending the preamble", e))?;

    status(s, peer, "reading the challenge").await?;
    let mut pre_l = [0u8; PREAMBLE_BYTES];
    s.read_exact(&mut pre_l)
        .await
        .map_err(|e| io(peer, "reading the challenge", e))?;
    let info = parse_preamble(&pre_l, peer)?;
    let mut nonce_l = [0u8; NONCE_BYTES];
    let mut mac_l = [0u8; NONCE_BYTES];
    s.read_exact(&mut nonce_l)
        .await
        .map_err(|e| io(peer, "reading the challenge", e))?;
    s.read_exact(&mut mac_l)
        .await
        .map_err(|e| io(peer, "reading the challenge", e))?;
    if !token.verify(LABEL_LISTENER, &[&hello, &pre_l, &nonce_l], &mac_l) {
        return Err(NetError::Handshake {
            peer: peer.to_string(),
            msg: "the peer could not prove it holds our token (different token files?)".into(),
        });
    }
    let mac_d = token.mac(LABEL_DIALER, &[&hello, &pre_l, &nonce_l, &mac_l]);
    s.write_all(&mac_d)
        .await
        .map_err(|e| io(peer, "sending the proof", e))?;
    s.flush()
        .await
        .map_err(|e| io(peer, "sending the proof", e))?;
    status(s, peer, "reading the verdict").await?;
    Ok(info)
}

/// The listening side. `peer` names the other end in errors.
pub async fn listen<S: AsyncRead + AsyncWrite + Unpin>(
    s: &mut S,
    token: &Token,
    role: Role,
    rank: u32,
    peer: &str,
) -> NetResult<PeerHello> {
    let mut hello = [0u8; PREAMBLE_BYTES + NONCE_BYTES];
    s.read_exact(&mut hello[..PREAMBLE_BYTES])
        .await
        .map_err(|e| io(peer, "reading the preamble", e))?;
    let pre_d: [u8; PREAMBLE_BYTES] = hello[..PREAMBLE_BYTES]
        .try_into()
        .unwrap_or([0; PREAMBLE_BYTES]);
    let info = match parse_preamble(&pre_d, peer) {
        Ok(i) => i,
        Err(e) => {
            // No detail to an unauthenticated peer: the reason is the
            // caller's (logged on this side).
            refuse(s, REFUSED).await;
            return Err(e);
        }
    };
    s.read_exact(&mut hello[PREAMBLE_BYTES..])
        .await
        .map_err(|e| io(peer, "reading the preamble", e))?;
    let pre_l = preamble(role, rank);
    let nonce_l = random_bytes::<NONCE_BYTES>()?;
    let mac_l = token.mac(LABEL_LISTENER, &[&hello, &pre_l, &nonce_l]);
    let mut ch = vec![0u8];
    ch.extend_from_slice(&pre_l);
    ch.extend_from_slice(&nonce_l);
    ch.extend_from_slice(&mac_l);
    s.write_all(&ch)
        .await
        .map_err(|e| io(peer, "sending the challenge", e))?;
    s.flush()
        .await
        .map_err(|e| io(peer, "sending the challenge", e))?;
    let mut mac_d = [0u8; NONCE_BYTES];
    s.read_exact(&mut mac_d)
        .await
        .map_err(|e| io(peer, "reading the proof", e))?;
    if !token.verify(LABEL_DIALER, &[&hello, &pre_l, &nonce_l, &mac_l], &mac_d) {
        refuse(s, REFUSED).await;
        return Err(NetError::Handshake {
            peer: peer.to_string(),
            msg: "authentication failed: wrong token, or a replayed handshake".into(),
        });
    }
    s.write_all(&[0u8])
        .await
        .map_err(|e| io(peer, "sending the verdict", e))?;
    s.flush()
        .await
        .map_err(|e| io(peer, "sending the verdict", e))?;
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::duplex;

    fn rt() -> tokio::runtime::Runtime {
        tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap()
    }

    fn tok(c: u8) -> Token {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t");
        std::fs::write(&p, vec![b'a' + c; 40]).unwrap();
        Token::load(&p).unwrap()
    }

    #[test]
    fn same_token_authenticates_both_ways() {
        rt().block_on(async {
            let (mut a, mut b) = duplex(4096);
            let t = tok(0);
            let (d, l) = tokio::join!(
                dial(&mut a, &t, Role::Coordinator, 8, "l"),
                listen(&mut b, &t, Role::Worker, 0, "d")
            );
            assert_eq!(
                d.unwrap(),
                PeerHello {
                    role: Role::Worker,
                    rank: 0
                }
            );
            assert_eq!(
                l.unwrap(),
                PeerHello {
                    role: Role::Coordinator,
                    rank: 8
                }
            );
        });
    }

    #[test]
    fn wrong_token_fails_on_both_sides() {
        rt().block_on(async {
            let (mut a, mut b) = duplex(4096);
            let (t0, t1) = (tok(0), tok(1));
            let (d, l) = tokio::join!(
                async {
                    let r = dial(&mut a, &t0, Role::Coordinator, 8, "worker").await;
                    drop(a); // as a real dialer closes on error
                    r
                },
                listen(&mut b, &t1, Role::Worker, 0, "coordinator")
            );
            let d = d.unwrap_err().to_string();
            assert!(d.contains("could not prove"), "{d}");
            assert!(l.is_err());
        });
    }

    /// Records a real dialer's bytes and replays them to a fresh listener:
    /// the listener's new nonce makes the recorded proof worthless.
    #[test]
    fn replayed_handshake_is_refused() {
        rt().block_on(async {
            let t = tok(2);
            let (mut a, mut b) = duplex(4096);
            // A listener that records what the dialer sends.
            let listener = async {
                let mut rec = Vec::new();
                let mut hello = [0u8; PREAMBLE_BYTES + NONCE_BYTES];
                b.read_exact(&mut hello).await.unwrap();
                rec.extend_from_slice(&hello);
                let pre_l = preamble(Role::Worker, 0);
                let nonce_l = [7u8; NONCE_BYTES];
                let mac_l = t.mac(LABEL_LISTENER, &[&hello, &pre_l, &nonce_l]);
                let mut ch = vec![0u8];
                ch.extend_from_slice(&pre_l);
                ch.extend_from_slice(&nonce_l);
                ch.extend_from_slice(&mac_l);
                b.write_all(&ch).await.unwrap();
                let mut proof = [0u8; NONCE_BYTES];
                b.read_exact(&mut proof).await.unwrap();
                rec.extend_from_slice(&proof);
                b.write_all(&[0]).await.unwrap();
                rec
            };
            let (d, rec) = tokio::join!(dial(&mut a, &t, Role::Coordinator, 1, "l"), listener);
            d.unwrap();
            // Replay to a real listener.
            let (mut a2, mut b2) = duplex(4096);
            let replay = async {
                a2.write_all(&rec).await.unwrap();
                let mut sink = Vec::new();
                let _ = a2.read_to_end(&mut sink).await;
                sink
            };
            let (l, answer) = tokio::join!(
                async {
                    let r = listen(&mut b2, &t, Role::Worker, 0, "replayer").await;
                    drop(b2);
                    r
                },
                replay
            );
            let e = l.unwrap_err().to_string();
            assert!(e.contains("replayed"), "{e}");
            let answer = String::from_utf8_lossy(&answer);
            assert!(answer.contains(REFUSED), "{answer}");
            assert!(!answer.contains("token"), "{answer}");
        });
    }

    #[test]
    fn garbage_is_not_a_pvrsim_peer() {
        rt().block_on(async {
            let (mut a, mut b) = duplex(4096);
            a.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
                .await
                .unwrap();
            let e = listen(&mut b, &tok(0), Role::Worker, 0, "x")
                .await
                .unwrap_err()
                .to_string();
            assert!(e.contains("not a pvrsim peer"), "{e}");
        });
    }

    /// A wrong protocol version is refused without saying so to the peer
    /// (the listener's own error says it).
    #[test]
    fn refusal_carries_no_detail() {
        rt().block_on(async {
            let (mut a, mut b) = duplex(4096);
            let mut p = preamble(Role::Coordinator, 1).to_vec();
            p[8] = 99;
            p.extend_from_slice(&[0u8; NONCE_BYTES]);
            a.write_all(&p).await.unwrap();
            let e = listen(&mut b, &tok(0), Role::Worker, 0, "x")
                .await
                .unwrap_err()
                .to_string();
            assert!(e.contains("protocol version 99"), "{e}");
            drop(b);
            let mut back = Vec::new();
            let _ = a.read_to_end(&mut back).await;
            let back = String::from_utf8_lossy(&back);
            assert!(
                back.contains(REFUSED) && !back.contains("version"),
                "{back}"
            );
        });
    }
}
