//! `--on-failure reassign`: when workers die in phase 1, their cells go to
//! the survivors and the frame runs again on them.
//!
//! A worker is *lost* when its link to the coordinator ended without
//! `Goodbye` (killed, crashed, silent past the heartbeat deadline); the
//! survivors give the frame up with a clean `Goodbye` once they notice the
//! loss, so the coordinator tells the two apart
//! ([`RemoteTransport::link_endings`]). Each survivor keeps its cells and takes
//! a contiguous share of the lost workers' cells ([`reassign_parts`]); the
//! frame then runs from the start on the survivors (their phase-1 work is
//! not kept: the lost worker's lists are gone, and phase 1's manager
//! protocol cannot drop a node mid-frame).

use std::time::Duration;

use anyhow::Context;

use super::coordinator::{Coordinator, Measured};
use crate::cluster::{ClusterConfig, ClusterOutcome};
use crate::net::{NodeId, RemoteTransport};
use crate::node::Placement;
use crate::render::RenderInput;

/// Workers that died in phase 1 (their links ended without `Goodbye`),
/// attached to the error of a failed frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LostWorkers {
    /// Their ranks.
    pub ranks: Vec<usize>,
    /// Their names.
    pub names: Vec<String>,
}

impl std::fmt::Display for LostWorkers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "phase 1: lost {}", self.names.join(", "))
    }
}

/// What `--on-failure reassign` did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Reassigned {
    /// The workers lost, by name.
    pub lost: Vec<String>,
    /// Their cells, given to the survivors.
    pub cells: u64,
    /// The error that ended the first attempt.
    pub first_error: String,
    /// The placement of the run that completed (survivors by new rank).
    #[serde(skip)]
    pub parts: Vec<Vec<u32>>,
}

/// The placement after losing `lost`: each survivor keeps its cells and
/// takes a contiguous share of the lost workers' cells (ascending ids);
/// survivors in rank order become ranks `0..`.
pub fn reassign_parts(parts: &[Vec<u32>], lost: &[usize]) -> Vec<Vec<u32>> {
    let orphans: Vec<u32> = lost
        .iter()
        .flat_map(|&k| parts[k].iter().copied())
        .collect();
    let mut out: Vec<Vec<u32>> = (0..parts.len())
        .filter(|k| !lost.contains(k))
        .map(|k| parts[k].clone())
        .collect();
    let s = out.len().max(1);
    for (i, part) in out.iter_mut().enumerate() {
        let (a, b) = (orphans.len() * i / s, orphans.len() * (i + 1) / s);
        part.extend_from_slice(&orphans[a..b]);
        part.sort_unstable();
    }
    out
}

impl Coordinator {
    /// Runs one frame on the workers; with [`Coordinator::reassign`], once
    /// more on the survivors if workers die in phase 1.
    pub fn run(
        &self,
        input: &RenderInput,
        cfg: &ClusterConfig,
    ) -> anyhow::Result<(ClusterOutcome, Measured)> {
        let n = cfg.phase1.nodes;
        anyhow::ensure!(
            self.workers.len() == n,
            "{} worker addresses for --nodes {n}: give one worker per node",
            self.workers.len()
        );
        let placement = Placement::new(&input.mesh, n, cfg.placement, Some(&input.scene.view()));
        let e = match self.run_placed(input, cfg, &placement) {
            Ok(x) => return Ok(x),
            Err(e) => e,
        };
        let Some(lost) = e.downcast_ref::<LostWorkers>().cloned() else {
            return Err(e);
        };
        if !self.reassign || lost.ranks.is_empty() || lost.ranks.len() >= n {
            return Err(e);
        }
        let parts = reassign_parts(&placement.parts, &lost.ranks);
        let cells: u64 = lost
            .ranks
            .iter()
            .map(|&k| placement.parts[k].len() as u64)
            .sum();
        eprintln!(
            "note: {e:#}\nnote: --on-failure reassign: {cells} cells of {} go to the {} survivors; the frame runs again on them",
            lost.names.join(", "),
            parts.len()
        );
        let survivors = Coordinator {
            workers: (0..n)
                .filter(|k| !lost.ranks.contains(k))
                .map(|k| self.workers[k].clone())
                .collect(),
            reassign: false,
            ..self.clone()
        };
        let mut cfg2 = cfg.clone();
        cfg2.phase1.nodes = parts.len();
        let placement2 = Placement {
            parts: parts.clone(),
        };
        let (out, mut m) = survivors
            .run_placed(input, &cfg2, &placement2)
            .context("the frame on the survivors (--on-failure reassign)")?;
        m.reassigned = Some(Reassigned {
            lost: lost.names,
            cells,
            first_error: format!("{e:#}"),
            parts,
        });
        Ok((out, m))
    }

    /// The workers whose links ended without `Goodbye` (waiting for the
    /// survivors to give up too), as an error context.
    pub(super) fn lost_in_phase1(
        &self,
        t: &impl RemoteTransport,
        n: usize,
        e: anyhow::Error,
    ) -> anyhow::Error {
        if !self.reassign {
            return e;
        }
        let endings = t.link_endings(self.tcp.deadline * 2 + Duration::from_secs(2));
        let ranks: Vec<usize> = (0..n).filter(|&k| endings[k] == Some(false)).collect();
        let names = ranks
            .iter()
            .map(|&k| t.peer_name(NodeId::from(k)))
            .collect();
        e.context(LostWorkers { ranks, names })
    }
}
