//! Opening authenticated links: dial a listener, accept a dialer, and the
//! address rule (no token, no exposure beyond loopback).

use std::net::SocketAddr;

use tokio::net::{TcpListener, TcpStream};

use super::auth::Token;
use super::handshake::{dial, listen, PeerHello, Role};
use super::transport::TcpOptions;
use crate::net::error::{NetError, NetResult};

/// True for 127.0.0.0/8 and ::1.
pub fn is_loopback(addr: &SocketAddr) -> bool {
    addr.ip().is_loopback()
}

/// Refuses to use a non-loopback address without a token.
pub fn check_exposure(addr: &SocketAddr, token: &Token, what: &str) -> NetResult<()> {
    if token.is_none() && !is_loopback(addr) {
        return Err(NetError::Io {
            what: format!("{what} {addr}"),
            msg: "refusing a non-loopback address without a token: pass --token-file FILE \
                  (at least 32 random bytes, the same file on every machine)"
                .into(),
        });
    }
    Ok(())
}

/// Connects to `addr` and runs the dialing side of the handshake, all
/// within `opts.handshake_timeout`. Sets `TCP_NODELAY`.
pub async fn connect(
    addr: &str,
    token: &Token,
    role: Role,
    rank: u32,
    opts: &TcpOptions,
) -> NetResult<(TcpStream, PeerHello)> {
    let t = opts.handshake_timeout;
    let work = async {
        // Checked before connecting: without a token nothing leaves loopback.
        let targets: Vec<SocketAddr> = tokio::net::lookup_host(addr)
            .await
            .map_err(|e| NetError::Io {
                what: format!("resolving {addr}"),
                msg: e.to_string(),
            })?
            .collect();
        for a in &targets {
            check_exposure(a, token, "connecting to")?;
        }
        let mut s = TcpStream::connect(&targets[..])
            .await
            .map_err(|e| NetError::Io {
                what: format!("connecting to {addr}"),
                msg: e.to_string(),
            })?;
        s.set_nodelay(true).map_err(|e| NetError::Io {
            what: format!("TCP_NODELAY on {addr}"),
            msg: e.to_string(),
        })?;
        let hello = dial(&mut s, token, role, rank, addr).await?;
        Ok((s, hello))
    };
    tokio::time::timeout(t, work)
        .await
        .map_err(|_| NetError::Handshake {
            peer: addr.to_string(),
            msg: format!(
                "no answer within {:.1} s (is a pvrsim worker listening there?)",
                t.as_secs_f64()
            ),
        })?
}

/// Accepts one connection on `listener` and runs the listening side of the
/// handshake within `opts.handshake_timeout`. A failed handshake is an
/// error for this connection only: the caller keeps listening.
pub async fn accept(
    listener: &TcpListener,
    token: &Token,
    role: Role,
    rank: u32,
    opts: &TcpOptions,
) -> NetResult<(TcpStream, PeerHello, SocketAddr)> {
    let (mut s, from) = listener.accept().await.map_err(|e| NetError::Io {
        what: "accepting a connection".into(),
        msg: e.to_string(),
    })?;
    let _ = s.set_nodelay(true);
    let name = from.to_string();
    let t = opts.handshake_timeout;
    let hello = tokio::time::timeout(t, listen(&mut s, token, role, rank, &name))
        .await
        .map_err(|_| NetError::Handshake {
            peer: name.clone(),
            msg: format!("no complete handshake within {:.1} s", t.as_secs_f64()),
        })??;
    Ok((s, hello, from))
}
