//! How a worker joins the mesh of its peers: `mesh` dials every lower
//! rank and accepts every higher one, `Mesh::transport` adds the
//! coordinator's link and builds the rank's transport. Used by the mesh
//! workers ([`super::worker`]) and the grid workers ([`super::grid`]).
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::runtime::Runtime;

use crate::net::tcp::frame::{TAG_GOODBYE, TAG_HEARTBEAT};
use crate::net::tcp::{self, Link, Role, TcpOptions, TcpTransport, Token};
use crate::net::{Codec, NodeId};

/// What a worker (mesh or grid) needs of its process to join a mesh of peers.
pub struct Mesh<'a> {
    /// The process's runtime.
    pub rt: &'a Arc<Runtime>,
    /// Its door (peers of higher rank dial it; the door authenticates
    /// them and hands them over).
    pub door: &'a super::accept::Door,
    /// The shared token.
    pub token: &'a Token,
    /// Link timing.
    pub opts: &'a TcpOptions,
}

impl Mesh<'_> {
    /// This rank's transport to its peers and the coordinator: dials the
    /// lower ranks and accepts the higher ones ([`mesh`]),
    /// adds the coordinator's link (`coord`, the session's stream), and
    /// runs them with `codec`'s frame limit. `session` is the frame's id
    /// (peers of another frame are refused). While the mesh forms, the
    /// coordinator's stream is watched: if it closes (the coordinator gave
    /// the frame up or died), the mesh is abandoned at once, so that the
    /// worker is free for the next frame.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn transport(
        &self,
        rank: u32,
        nodes: u32,
        peers: &[String],
        session: [u8; 16],
        coord: NodeId,
        name: String,
        mut stream: TcpStream,
        codec: Codec,
    ) -> anyhow::Result<TcpTransport> {
        let formed = self.rt.block_on(async {
            tokio::select! {
                r = mesh(self.door, self.token, self.opts, rank, nodes, peers, session) => r.map_err(|e| (e, true)),
                e = watch_coordinator(&mut stream, &name, self.opts.heartbeat) => Err((e, false)),
            }
        });
        let mut links = match formed {
            Ok(l) => l,
            Err((e, tell)) => {
                if tell {
                    // Say why and end cleanly (Goodbye), so that the
                    // coordinator blames the peer that failed, not us.
                    let why = crate::cluster::remote::session::Session::Failed(format!(
                        "node {rank}, set-up (joining the mesh): {e:#}"
                    ));
                    let _ = self.rt.block_on(async {
                        let w = async {
                            tcp::raw::write_msg(
                                &mut stream,
                                &codec,
                                NodeId(rank),
                                coord,
                                &why,
                                &name,
                            )
                            .await?;
                            stream.write_all(&[TAG_GOODBYE]).await?;
                            let _ = stream.shutdown().await;
                            Ok::<_, anyhow::Error>(())
                        };
                        tokio::time::timeout(self.opts.handshake_timeout, w).await
                    });
                }
                return Err(e);
            }
        };
        links.push(Link {
            rank: coord,
            name,
            stream,
        });
        let opts = TcpOptions {
            codec,
            ..*self.opts
        };
        Ok(TcpTransport::new(
            Arc::clone(self.rt),
            NodeId(rank),
            nodes as usize + 1,
            links,
            opts,
        )?)
    }
}

/// Waits on the coordinator's stream while the mesh forms: the
/// coordinator sends nothing but heartbeats before every worker is ready,
/// so an end of stream, a goodbye or any other byte ends the wait with
/// the error to give up on; meanwhile it sends heartbeats every
/// `heartbeat`. Cancel safe (a read that has not completed takes nothing
/// from the stream; a heartbeat is one byte).
async fn watch_coordinator(s: &mut TcpStream, name: &str, heartbeat: Duration) -> anyhow::Error {
    let mut buf = [0u8; 64];
    let (mut r, mut w) = s.split();
    let mut tick = tokio::time::interval(heartbeat);
    loop {
        tokio::select! {
            got = r.read(&mut buf) => match got {
                Ok(0) => {
                    return anyhow::anyhow!(
                        "{name} closed the connection while the mesh was forming (it gave the frame up)"
                    )
                }
                Ok(n) => match buf[..n].iter().find(|&&b| b != TAG_HEARTBEAT) {
                    None => {}
                    Some(&TAG_GOODBYE) => {
                        return anyhow::anyhow!(
                            "{name} ended the session (Goodbye) while the mesh was forming"
                        )
                    }
                    Some(b) => {
                        return anyhow::anyhow!(
                            "{name} sent a frame (tag {b}) while the mesh was forming; expected only heartbeats"
                        )
                    }
                },
                Err(e) => return anyhow::anyhow!("{name}: {e} while the mesh was forming"),
            },
            // Heartbeats to the coordinator, so that a mesh slow to form
            // (a peer that does not answer) does not look like a stall of
            // this worker.
            _ = tick.tick() => {
                if let Err(e) = w.write_all(&[TAG_HEARTBEAT]).await {
                    return anyhow::anyhow!("{name}: {e} while the mesh was forming");
                }
            }
        }
    }
}

/// Dials every lower rank and accepts every higher one, concurrently
/// (rank `me` of `nodes` workers at `peers`). Each dialer states the
/// frame's id (`session`, 16 bytes) after the handshake; an accepted peer
/// with another id (a link left over from an earlier frame, or one for a
/// later frame) is closed and not counted.
pub(super) async fn mesh(
    door: &super::accept::Door,
    token: &Token,
    opts: &TcpOptions,
    me: u32,
    nodes: u32,
    peers: &[String],
    session: [u8; 16],
) -> anyhow::Result<Vec<Link>> {
    let dial = async {
        let mut links = Vec::new();
        for j in 0..me {
            let addr = &peers[j as usize];
            let (mut s, hello) = tcp::connect(addr, token, Role::Worker, me, opts)
                .await
                .with_context(|| format!("node {me} connecting to node {j} at {addr}"))?;
            s.write_all(&session)
                .await
                .with_context(|| format!("node {me} connecting to node {j} at {addr}"))?;
            anyhow::ensure!(
                hello.role == Role::Worker,
                "{addr} (node {j}) answered as {:?}, not as a worker",
                hello.role
            );
            links.push(Link {
                rank: NodeId(j),
                name: format!("worker {j} ({addr})"),
                stream: s,
            });
        }
        Ok::<_, anyhow::Error>(links)
    };
    let accept = async {
        let mut links: Vec<Link> = Vec::new();
        let want = (nodes - me - 1) as usize;
        let limit = opts.handshake_timeout * 2 + Duration::from_secs(5);
        let all = async {
            while links.len() < want {
                match door.next_peer().await {
                    Some(super::accept::Accepted {
                        stream: mut s,
                        hello: h,
                        from,
                    }) => {
                        let mut id = [0u8; 16];
                        let same = matches!(
                            tokio::time::timeout(opts.handshake_timeout, s.read_exact(&mut id))
                                .await,
                            Ok(Ok(_))
                        ) && id == session;
                        if !same {
                            crate::cluster::remote::hooks::say(&format!(
                                "node {me}: a peer from {from} (rank {}) belongs to another frame; closed",
                                h.rank
                            ));
                            continue;
                        }
                        let ok = h.role == Role::Worker
                            && h.rank > me
                            && h.rank < nodes
                            && !links.iter().any(|l| l.rank.0 == h.rank);
                        if ok {
                            links.push(Link {
                                rank: NodeId(h.rank),
                                name: format!("worker {} ({})", h.rank, peers[h.rank as usize]),
                                stream: s,
                            });
                        } else {
                            crate::cluster::remote::hooks::say(&format!(
                                "node {me}: unexpected {:?} rank {} from {from} while joining the mesh; closed",
                                h.role, h.rank
                            ));
                        }
                    }
                    None => std::future::pending::<()>().await,
                }
            }
        };
        tokio::time::timeout(limit, all).await.map_err(|_| {
            anyhow::anyhow!(
                "node {me}: only {} of the {want} higher-ranked workers connected within {:.0} s",
                links.len(),
                limit.as_secs_f64()
            )
        })?;
        Ok::<_, anyhow::Error>(links)
    };
    let (a, b) = tokio::join!(dial, accept);
    let mut links = a?;
    links.extend(b?);
    Ok(links)
}
