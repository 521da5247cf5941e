//! A session's nodes on whichever transport holds them ([`LiveNodes`]):
//! TCP links to worker processes or TCP workers ([`LiveCluster`]), or the
//! ranks of an MPI job (`MpiCluster`, feature `mpi`). The job layer drives
//! both through the same two calls: a frame, and the end.

use super::live::{LiveCluster, Work};
use super::measured::Measured;
use crate::cluster::{ClusterConfig, ClusterOutcome};

/// See the module docs.
pub enum LiveNodes {
    /// Worker processes or TCP workers, over TCP links.
    Links(LiveCluster),
    /// The node ranks of an MPI job (this process is rank 0).
    #[cfg(feature = "mpi")]
    Mpi(super::mpi::MpiCluster),
}

impl LiveNodes {
    /// One frame on the session's nodes.
    pub fn frame(
        &mut self,
        work: Work<'_>,
        cfg: &ClusterConfig,
    ) -> anyhow::Result<(ClusterOutcome, Measured)> {
        match self {
            LiveNodes::Links(l) => l.frame(work, cfg),
            #[cfg(feature = "mpi")]
            LiveNodes::Mpi(m) => m.frame(work, cfg),
        }
    }

    /// Ends the session: the nodes are told, the links close.
    pub fn end(&mut self) {
        match self {
            LiveNodes::Links(l) => l.end(),
            #[cfg(feature = "mpi")]
            LiveNodes::Mpi(m) => m.end(),
        }
    }
}
