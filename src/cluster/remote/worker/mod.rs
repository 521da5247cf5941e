//! The worker process (`pvrsim worker`): listens, authenticates the
//! coordinator, builds its node from the set-up, joins the mesh of peers,
//! runs the [`NodeActor`](crate::node::NodeActor) with the same thread driver loop as `--clock wall`
//! ([`run_actor`](crate::net::run_actor)) and sends its results; then, when the coordinator says
//! every node is done, runs its part of phase 2 worker to worker
//! ([`super::phase2`]). Then it serves the next session, or exits
//! (`--once`). Cells are cached by SHA-256 across sessions.
//!
//! Files: this one is the process (listen, authenticate, sessions, the
//! cells' cache); `node.rs` runs one node's frame over any transport (TCP
//! and MPI workers both end there).

pub mod next;
mod node;

pub use crate::cluster::remote::accept::{Accepted, Door, MAX_PENDING, PRE_AUTH};
pub use crate::cluster::remote::hooks::Hooks;
pub use node::{build_node, run_node, Held};

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::net::TcpListener;
use tokio::runtime::Runtime;

use crate::cluster::remote::session::{Session, WorkerSetup};
use crate::net::tcp::{self, Role, TcpOptions, Token};
use crate::net::{Codec, NodeId, RemoteTransport};

/// Longest an authenticated coordinator may wait before it sends its
/// set-up (it sends it right after the handshake).
const SETUP_IDLE: Duration = Duration::from_secs(5);

/// How many datasets' cells a worker keeps.
const CACHE_ENTRIES: usize = 4;

/// A bound worker, ready to serve.
pub struct Worker {
    rt: Arc<Runtime>,
    door: Door,
    token: Token,
    opts: TcpOptions,
    cache: VecDeque<([u8; 32], Vec<u8>)>,
    grid: crate::cluster::remote::grid::GridWorkerCache,
    /// Give up if no session starts within this (`None`: wait forever).
    pub accept_timeout: Option<Duration>,
    /// Test hook (hidden `--test-kill-after-chunks K`): the process kills
    /// itself with SIGKILL when its node starts chunk `K + 1` of phase 1,
    /// a deterministic `kill -9` mid-frame.
    pub kill_after_chunks: Option<u64>,
    /// Test hook (hidden `--test-kill-in-phase2`): SIGKILL when phase 2
    /// starts, a deterministic death in phase 2.
    pub kill_in_phase2: bool,
    /// Test hook (hidden `--test-kill-at-setup`): SIGKILL once a mesh
    /// set-up has arrived and been validated, before the peer links are
    /// dialled: a deterministic death at set-up.
    pub kill_at_setup: bool,
    /// Test hook (hidden `--test-kill-at-frame F`): SIGKILL when phase 1
    /// of the session's frame `F` (counted from 1) starts: a loss in the
    /// middle of a series.
    pub kill_at_frame: Option<u64>,
}

/// Test hook (hidden `--test-stop`): the kill hooks stop the process with
/// SIGSTOP instead (a stalled worker at a known point; it runs on when
/// sent SIGCONT). Process-wide.
pub fn hooks_stop_instead() {
    crate::cluster::remote::hooks::HOOK_STOPS.store(true, std::sync::atomic::Ordering::SeqCst);
}

impl Worker {
    /// Binds `addr` (port 0: any free port). Refuses a non-loopback address
    /// without a token.
    pub fn bind(addr: &str, token: Token, opts: TcpOptions) -> anyhow::Result<Worker> {
        // Checked before binding: a refused address is never opened.
        let addrs: Vec<std::net::SocketAddr> = std::net::ToSocketAddrs::to_socket_addrs(addr)
            .with_context(|| format!("--listen {addr}: not an address (host:port)"))?
            .collect();
        for a in &addrs {
            tcp::check_exposure(a, &token, "listening on")?;
        }
        let rt = tcp::runtime()?;
        let listener = rt
            .block_on(TcpListener::bind(addr))
            .with_context(|| format!("cannot listen on {addr}"))?;
        let local = listener.local_addr()?;
        tcp::check_exposure(&local, &token, "listening on")?;
        let door = Door::open(&rt, listener, token.clone(), opts);
        Ok(Worker {
            rt,
            door,
            token,
            opts,
            cache: VecDeque::new(),
            grid: Default::default(),
            accept_timeout: None,
            kill_after_chunks: None,
            kill_in_phase2: false,
            kill_at_setup: false,
            kill_at_frame: None,
        })
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> anyhow::Result<std::net::SocketAddr> {
        Ok(self.door.local_addr())
    }

    /// Serves sessions; with `once`, returns after the first one (its
    /// outcome). Connections that fail the handshake are reported on stderr
    /// and do not count.
    pub fn serve(&mut self, once: bool) -> anyhow::Result<()> {
        // Sessions check it before their last message (a frame given up
        // while this process was stopped).
        crate::net::stall::watch();
        loop {
            let next = self.door.next_session();
            let acc = match self.accept_timeout {
                None => self.rt.block_on(next),
                Some(t) => match self
                    .rt
                    .block_on(async { tokio::time::timeout(t, next).await })
                {
                    Ok(r) => r,
                    Err(_) => anyhow::bail!(
                        "no coordinator started a session within {:.0} s (--accept-timeout)",
                        t.as_secs_f64()
                    ),
                },
            };
            let Some(Accepted {
                stream,
                hello,
                from,
            }) = acc
            else {
                anyhow::bail!("the worker stopped accepting connections");
            };
            let r = match hello.role {
                Role::Probe => crate::cluster::remote::probe::echo(&self.rt, stream, &self.opts)
                    .map_err(anyhow::Error::from),
                _ => self.session(stream, hello.rank, from.to_string()),
            };
            self.door.session_done();
            match &r {
                Ok(()) => {
                    crate::cluster::remote::hooks::progress(&format!("session with {from} done"))
                }
                Err(e) => crate::cluster::remote::hooks::say(&format!(
                    "session with {from} failed: {e:#}"
                )),
            }
            if once {
                return r;
            }
        }
    }

    fn session(
        &mut self,
        mut stream: tokio::net::TcpStream,
        coord_rank: u32,
        coord_name: String,
    ) -> anyhow::Result<()> {
        let codec = Codec::default();
        let d = self.opts.deadline.max(Duration::from_secs(10));
        let coord = NodeId(coord_rank);
        let name = format!("the coordinator ({coord_name})");
        // Set-up on the bare stream; a coordinator sends it right after the
        // handshake, so an idle one is dropped after SETUP_IDLE.
        let setup: Session = self.rt.block_on(tcp::raw::read_msg(
            &mut stream,
            &codec,
            SETUP_IDLE.min(d),
            &name,
        ))?;
        crate::cluster::remote::hooks::progress(&format!("a set-up from {name}"));
        let setup = match setup {
            Session::Setup(s) => s,
            Session::Grid(g) => match *g {
                crate::cluster::remote::grid_wire::GridMsg::Setup(s) => {
                    if self.kill_at_setup {
                        crate::cluster::remote::hooks::kill_self(
                            "at set-up (--test-kill-at-setup)",
                        );
                    }
                    self.door.set_rank(s.rank);
                    return crate::cluster::remote::grid::serve(
                        &self.rt,
                        stream,
                        &mut self.cache,
                        CACHE_ENTRIES,
                        &mut self.grid,
                        crate::cluster::remote::mesh::Mesh {
                            rt: &self.rt,
                            door: &self.door,
                            token: &self.token,
                            opts: &self.opts,
                        },
                        *s,
                        coord,
                        &name,
                        Hooks {
                            kill_after_chunks: self.kill_after_chunks,
                            kill_in_phase2: self.kill_in_phase2,
                            ..Hooks::default()
                        },
                    );
                }
                other => anyhow::bail!("{name} sent {other:?} instead of the set-up"),
            },
            other => anyhow::bail!("{name} sent {other:?} instead of the set-up"),
        };
        setup
            .validate()
            .map_err(|e| anyhow::anyhow!("bad set-up from {name}: {e}"))?;
        anyhow::ensure!(
            coord_rank == setup.nodes,
            "{name} says it is rank {coord_rank}, but the set-up has {} nodes",
            setup.nodes
        );
        if self.kill_at_setup {
            crate::cluster::remote::hooks::kill_self("at set-up (--test-kill-at-setup)");
        }
        let me = NodeId(setup.rank);
        self.door.set_rank(setup.rank);
        let codec = Codec::with_limit(setup.max_message_bytes);
        // Pieces the worker reads itself: nothing to send (read once the
        // mesh of peers is up, see node::build_node).
        let pieces = setup.pieces.is_some();
        let cached = self
            .cache
            .iter()
            .position(|(h, _)| *h == setup.cells_sha256);
        self.rt.block_on(tcp::raw::write_msg(
            &mut stream,
            &codec,
            me,
            coord,
            &Session::Need(!pieces && cached.is_none()),
            &name,
        ))?;
        let cells = match cached {
            _ if pieces => Vec::new(),
            Some(i) => self.cache[i].1.clone(),
            None => {
                let m: Session =
                    self.rt
                        .block_on(tcp::raw::read_msg(&mut stream, &codec, d, &name))?;
                let Session::Cells(bytes) = m else {
                    anyhow::bail!("{name} sent {m:?} instead of the cells");
                };
                anyhow::ensure!(
                    crate::cluster::remote::session::sha256(&bytes) == setup.cells_sha256,
                    "the cells from {name} do not match their SHA-256"
                );
                if self.cache.len() >= CACHE_ENTRIES {
                    self.cache.pop_front();
                }
                self.cache.push_back((setup.cells_sha256, bytes.clone()));
                bytes
            }
        };
        // The mesh: dial lower ranks, accept higher ones.
        let t = crate::cluster::remote::mesh::Mesh {
            rt: &self.rt,
            door: &self.door,
            token: &self.token,
            opts: &self.opts,
        }
        .transport(
            setup.rank,
            setup.nodes,
            &setup.peers,
            setup.session_id,
            coord,
            name,
            stream,
            codec,
        )?;
        let mut hooks = Hooks {
            kill_after_chunks: self.kill_after_chunks,
            kill_in_phase2: self.kill_in_phase2,
            kill_at_frame: self.kill_at_frame,
            frame: 0,
        };
        // The session's frames on these links, until the coordinator ends it.
        let mut setup = setup;
        let mut cells = cells;
        let mut held = None;
        loop {
            hooks.frame += 1;
            run_node(&t, &setup, &cells, &mut held, d, hooks)?;
            let between = std::time::Instant::now();
            let r = next::next_frame(&t, &setup, codec, d).and_then(|n| match n {
                next::Next::End => Ok(None),
                next::Next::Frame(s) => {
                    let c = self.next_cells(&t, &s, held.as_ref(), codec, d)?;
                    Ok(Some((s, c)))
                }
            });
            match r {
                Ok(None) => {
                    t.close(Duration::from_secs(10));
                    return Ok(());
                }
                Ok(Some((s, c))) => {
                    if c.is_some() || s.pieces != setup.pieces {
                        held = None;
                    }
                    setup = s;
                    cells = c.unwrap_or_default();
                }
                Err(e) => {
                    let why = format!("node {} between frames: {e:#}", setup.rank);
                    crate::cluster::remote::guard::report_failure(&t, coord, &codec, &why, between);
                    t.close(Duration::from_secs(2));
                    anyhow::bail!(why);
                }
            }
        }
    }

    /// The cells of a session's next frame `next`: `None` when the node's
    /// data stays (the same cells, or pieces: `Need(false)`); else the
    /// cells, from the cache or the coordinator (`Need(true)`, then
    /// `Cells` over the session's links).
    fn next_cells<T: crate::net::RemoteTransport>(
        &mut self,
        t: &T,
        next: &WorkerSetup,
        held: Option<&Held>,
        codec: Codec,
        wait: Duration,
    ) -> anyhow::Result<Option<Vec<u8>>> {
        let coord = NodeId(next.nodes);
        let kept = next.pieces.is_some() || held.is_some_and(|h| h.key == next.cells_sha256);
        let cached = self.cache.iter().position(|(h, _)| *h == next.cells_sha256);
        let need = !kept && cached.is_none();
        t.send(
            coord,
            crate::net::MessageKind::Session,
            codec.encode(&Session::Need(need))?,
        )?;
        if kept {
            return Ok(None);
        }
        if let Some(i) = cached {
            return Ok(Some(self.cache[i].1.clone()));
        }
        let bytes = next::recv_cells(t, coord, &next.cells_sha256, codec, wait)?;
        if self.cache.len() >= CACHE_ENTRIES {
            self.cache.pop_front();
        }
        self.cache.push_back((next.cells_sha256, bytes.clone()));
        Ok(Some(bytes))
    }
}
