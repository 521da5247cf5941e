//! In-process transport: one unbounded `crossbeam-channel` inbox per rank,
//! every endpoint holding a sender to every inbox. For running node and
//! manager code in threads of one process with wall-clock time.

use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender, TryRecvError};

use super::error::{NetError, NetResult};
use super::message::{Envelope, MessageKind, NodeId};
use super::transport::{check_rank, Transport};

/// Builds the endpoints of an in-process network.
pub struct ChannelNetwork;

impl ChannelNetwork {
    /// `n` connected endpoints; element `i` has rank `i`. Move each into its
    /// thread (they are `Send + Sync`).
    #[allow(clippy::new_ret_no_self)]
    pub fn new(n: usize) -> Vec<ChannelTransport> {
        let (senders, receivers): (Vec<_>, Vec<_>) =
            (0..n).map(|_| crossbeam_channel::unbounded()).unzip();
        let senders: Arc<[Sender<Envelope>]> = senders.into();
        receivers
            .into_iter()
            .enumerate()
            .map(|(i, inbox)| ChannelTransport {
                rank: NodeId::from(i),
                senders: Arc::clone(&senders),
                inbox,
            })
            .collect()
    }
}

/// One rank's endpoint of a [`ChannelNetwork`].
pub struct ChannelTransport {
    rank: NodeId,
    senders: Arc<[Sender<Envelope>]>,
    inbox: Receiver<Envelope>,
}

impl Transport for ChannelTransport {
    fn rank(&self) -> NodeId {
        self.rank
    }

    fn size(&self) -> usize {
        self.senders.len()
    }

    fn send(&self, to: NodeId, kind: MessageKind, payload: Vec<u8>) -> NetResult<()> {
        check_rank(to, self.size())?;
        let env = Envelope {
            from: self.rank,
            to,
            kind,
            payload,
        };
        self.senders[to.index()]
            .send(env)
            .map_err(|_| NetError::Disconnected { rank: self.rank })
    }

    fn recv(&self) -> NetResult<Envelope> {
        self.inbox
            .recv()
            .map_err(|_| NetError::Disconnected { rank: self.rank })
    }

    fn recv_timeout(&self, timeout: Duration) -> NetResult<Option<Envelope>> {
        match self.inbox.recv_timeout(timeout) {
            Ok(e) => Ok(Some(e)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(NetError::Disconnected { rank: self.rank }),
        }
    }

    fn try_recv(&self) -> NetResult<Option<Envelope>> {
        match self.inbox.try_recv() {
            Ok(e) => Ok(Some(e)),
            Err(TryRecvError::Empty) => Ok(None),
            Err(TryRecvError::Disconnected) => Err(NetError::Disconnected { rank: self.rank }),
        }
    }
}
