//! How a worker joins the mesh of its peers: `mesh` dials every lower
//! rank and accepts every higher one, `Mesh::transport` adds the
//! coordinator's link and builds the rank's transport. Used by the mesh
//! workers ([`super::worker`]) and the grid workers ([`super::grid`]).
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::net::TcpStream;
use tokio::runtime::Runtime;

use crate::net::tcp::{self, Link, Role, TcpOptions, TcpTransport, Token};
use crate::net::{Codec, NodeId};

/// What a worker (mesh or grid) needs of its process to join a mesh of peers.
pub struct Mesh<'a> {
    /// The process's runtime.
    pub rt: &'a Arc<Runtime>,
    /// Its door (peers of higher rank dial it; the door authenticates
    /// them and hands them over).
    pub door: &'a super::worker::Door,
    /// The shared token.
    pub token: &'a Token,
    /// Link timing.
    pub opts: &'a TcpOptions,
}

impl Mesh<'_> {
    /// This rank's transport to its peers and the coordinator: dials the
    /// lower ranks and accepts the higher ones ([`mesh`]),
    /// adds the coordinator's link (`coord`, the session's stream), and
    /// runs them with `codec`'s frame limit.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn transport(
        &self,
        rank: u32,
        nodes: u32,
        peers: &[String],
        coord: NodeId,
        name: String,
        stream: TcpStream,
        codec: Codec,
    ) -> anyhow::Result<TcpTransport> {
        let mut links = self
            .rt
            .block_on(mesh(self.door, self.token, self.opts, rank, nodes, peers))?;
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

/// Dials every lower rank and accepts every higher one, concurrently
/// (rank `me` of `nodes` workers at `peers`).
pub(super) async fn mesh(
    door: &super::worker::Door,
    token: &Token,
    opts: &TcpOptions,
    me: u32,
    nodes: u32,
    peers: &[String],
) -> anyhow::Result<Vec<Link>> {
    let dial = async {
        let mut links = Vec::new();
        for j in 0..me {
            let addr = &peers[j as usize];
            let (s, hello) = tcp::connect(addr, token, Role::Worker, me, opts)
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
                    Some(super::worker::Accepted {
                        stream: s,
                        hello: h,
                        from,
                    }) => {
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
                            eprintln!(
                                "pvrsim worker: node {me}: unexpected {:?} rank {} from {from} while joining the mesh; closed",
                                h.role, h.rank
                            );
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
