//! The transport contract: what node, manager and compositor code may do
//! with the network. Implementations: [`crate::net::ChannelTransport`]
//! (threads in one process), [`crate::net::Metered`] (a counting wrapper),
//! [`crate::net::tcp::TcpTransport`] (processes and machines) and, with the
//! `mpi` feature, `crate::net::mpi::MpiTransport` (under `mpirun`).
//!
//! Modelled on IceT's communicator (send, recv, sendrecv, isend/irecv, size,
//! rank), cut to what a cluster of nodes plus a manager needs:
//!
//! - `send` is *buffered*: it queues the message and returns, like an eager
//!   `MPI_Isend` whose request is never waited on. There is no separate
//!   `isend`, and no deadlock from two ranks sending to each other first.
//! - `recv` takes the next message from *any* source (the manager serves
//!   whoever asks); [`Mailbox::recv_from`] adds selective receive for
//!   pairwise protocols such as binary swap.
//! - Messages from one sender to one receiver arrive in send order.
//!   Messages from different senders are not ordered against each other.

use std::collections::VecDeque;
use std::time::Duration;

use super::error::{NetError, NetResult};
use super::message::{Codec, Envelope, Message, MessageKind, NodeId};

/// A rank's endpoint on a network of [`Transport::size`] ranks.
pub trait Transport {
    /// This endpoint's rank.
    fn rank(&self) -> NodeId;

    /// Number of ranks in the network.
    fn size(&self) -> usize;

    /// Queues `payload` for `to`. Returns once queued; fails if `to` is out
    /// of range or the receiver is gone.
    fn send(&self, to: NodeId, kind: MessageKind, payload: Vec<u8>) -> NetResult<()>;

    /// Blocks until a message from any rank arrives.
    fn recv(&self) -> NetResult<Envelope>;

    /// Waits at most `timeout` for a message; `Ok(None)` on timeout.
    fn recv_timeout(&self, timeout: Duration) -> NetResult<Option<Envelope>>;

    /// Returns a message if one is waiting, without blocking.
    fn try_recv(&self) -> NetResult<Option<Envelope>>;

    /// Encodes and sends a typed message.
    fn send_msg<M: Message>(&self, codec: &Codec, to: NodeId, msg: &M) -> NetResult<()>
    where
        Self: Sized,
    {
        self.send(to, M::KIND, codec.encode(msg)?)
    }
}

/// Checks a destination against the network size (for implementations).
pub fn check_rank(to: NodeId, size: usize) -> NetResult<()> {
    if to.index() < size {
        Ok(())
    } else {
        Err(NetError::NoSuchRank { to, size })
    }
}

/// Selective receive on top of any transport: messages that do not match
/// are kept, in arrival order, for later calls.
///
/// ```
/// use pvrsim::net::{ChannelNetwork, Mailbox, MessageKind, NodeId, Transport};
/// let net = ChannelNetwork::new(3);
/// net[1].send(NodeId(0), MessageKind::Control, vec![1]).unwrap();
/// net[2].send(NodeId(0), MessageKind::Image, vec![2]).unwrap();
/// let mut mb = Mailbox::new(&net[0]);
/// let e = mb.recv_from(NodeId(2), MessageKind::Image).unwrap();
/// assert_eq!(e.payload, vec![2]);
/// assert_eq!(mb.recv().unwrap().payload, vec![1]); // kept for later
/// ```
pub struct Mailbox<'a, T: Transport> {
    transport: &'a T,
    pending: VecDeque<Envelope>,
}

impl<'a, T: Transport> Mailbox<'a, T> {
    /// Wraps a transport.
    pub fn new(transport: &'a T) -> Self {
        Mailbox {
            transport,
            pending: VecDeque::new(),
        }
    }

    /// The next message from any rank (kept messages first).
    pub fn recv(&mut self) -> NetResult<Envelope> {
        match self.pending.pop_front() {
            Some(e) => Ok(e),
            None => self.transport.recv(),
        }
    }

    /// The first message from `from` of kind `kind`; others are kept.
    pub fn recv_from(&mut self, from: NodeId, kind: MessageKind) -> NetResult<Envelope> {
        if let Some(i) = self
            .pending
            .iter()
            .position(|e| e.from == from && e.kind == kind)
        {
            if let Some(e) = self.pending.remove(i) {
                return Ok(e);
            }
        }
        loop {
            let e = self.transport.recv()?;
            if e.from == from && e.kind == kind {
                return Ok(e);
            }
            self.pending.push_back(e);
        }
    }

    /// Sends to `to` and then receives `to`'s message of the same kind (an
    /// exchange, as in one binary-swap round). Safe because sends are
    /// buffered.
    pub fn sendrecv(
        &mut self,
        to: NodeId,
        kind: MessageKind,
        payload: Vec<u8>,
    ) -> NetResult<Envelope> {
        self.transport.send(to, kind, payload)?;
        self.recv_from(to, kind)
    }
}
