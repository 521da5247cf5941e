//! [`ShardActor`]: one shard of a sharded manager (`--manager-shards K`).
//!
//! With per-pixel sharing the manager's work is per pixel: it combines
//! every node's level codes into certified termination depths and cuts
//! each node's reply from a per-tile change log
//! ([`crate::node::pixel_share::PixelStore`]). Pixels never interact, so
//! the screen can be split: shard `s` owns the tiles
//! [`ShardMap::shard_of_tile`] gives it, keeps the store for those tiles
//! only, and answers each share with the certified depths of its tiles
//! under the sender's footprint that changed since its last reply to that
//! sender. The entries keep the paper's format (a listed pixel is
//! terminated, its code is the minimum `deepest`), and the combination rule
//! (the `L`-th smallest code per pixel) is unchanged, so the certified depth
//! of every pixel is the one the single manager would compute from the same
//! shares.
//!
//! Shard 0 is the [`super::ManagerActor`] itself (rank `N`), which also
//! balances the load and ends phase 1; shards `1..K` are `ShardActor`s at
//! ranks `N + 1 .. N + K`. A shard does ERT only: it never waits for
//! anybody, stops on the manager's [`Control::Finish`], and reports a
//! protocol error (a malformed share, a pixel it does not own) to the
//! manager with [`Control::Abort`], which ends phase 1 for everyone.
//!
//! **Where the shards run.** On dedicated manager PCs, like the paper's
//! manager: `K - 1` more machines, each with its own NIC in the network
//! model, charged `per_shared_entry` per code read or written as the
//! manager is. Co-locating a shard on a worker node would put its merges on
//! that node's scan time (the critical path) and make shares wait for the
//! node's next chunk boundary (it reads messages between chunks only).

use super::protocol::{Control, ErtReply, ErtShare};
use crate::net::{Action, Activity, Actor, Codec, Envelope, Event, MessageKind, NodeId};
use crate::node::pixel_share::{PixelDepths, PixelLevels, PixelStore};
use crate::node::shard_map::ShardMap;
use crate::node::CostProfile;

/// What one shard did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ShardStats {
    /// Shares served.
    pub shares_merged: u64,
    /// Entries sent back (certified depths that changed).
    pub entries_improved: u64,
    /// Modelled seconds spent combining and replying.
    pub busy_s: f64,
    /// First protocol error seen, if any.
    pub error: Option<String>,
}

/// Serves node `j`'s per-pixel share `bytes` at shard `s` of `map`: checks
/// that every pixel belongs to the shard, combines, and cuts the reply.
/// Returns the reply and the work (codes compared, log entries walked,
/// entries packed) for the cost model.
pub fn serve_pixel_share(
    store: &mut PixelStore,
    map: &ShardMap,
    s: usize,
    j: usize,
    bytes: &[u8],
) -> Result<(PixelDepths, u64), String> {
    let (w, h, l) = store.shape();
    let d = PixelLevels::decode(bytes, w, h, l).map_err(|e| e.to_string())?;
    if let Some(&(p, _)) = d
        .pixels
        .iter()
        .find(|(p, _)| map.shard_of_pixel(*p, w) != s)
    {
        return Err(format!(
            "share from node {j}: pixel ({}, {}) belongs to manager shard {}, not {s}",
            p % w,
            p / w,
            map.shard_of_pixel(p, w)
        ));
    }
    let work = store.apply(j, &d).map_err(|e| e.to_string())?;
    let (reply, rwork) = store.reply(j);
    Ok((reply, work + rwork))
}

/// A manager shard `s >= 1` at rank `nodes + s`. See the module docs.
#[derive(Debug)]
pub struct ShardActor {
    shard: usize,
    nodes: usize,
    map: ShardMap,
    codec: Codec,
    profile: CostProfile,
    store: PixelStore,
    stopped: bool,
    stats: ShardStats,
}

impl ShardActor {
    /// Shard `shard` of `map` for `nodes` nodes, per-pixel sharing of a
    /// `width x height` image with `levels` levels.
    pub fn new(
        shard: usize,
        map: ShardMap,
        nodes: usize,
        (width, height, levels): (u32, u32, usize),
        profile: CostProfile,
        codec: Codec,
    ) -> ShardActor {
        ShardActor {
            shard,
            nodes,
            map,
            codec,
            profile,
            store: PixelStore::new(width, height, levels, nodes),
            stopped: false,
            stats: ShardStats::default(),
        }
    }

    /// What the shard did.
    pub fn stats(&self) -> &ShardStats {
        &self.stats
    }

    /// The certified depth code of every pixel (those of other shards'
    /// tiles stay "not reached").
    pub fn certified(&self) -> &[u16] {
        self.store.certified()
    }

    fn on_message(&mut self, env: Envelope, out: &mut Vec<Action>) -> Result<(), String> {
        let j = env.from.index();
        match env.kind {
            MessageKind::ErtShare if j < self.nodes => {
                let m: ErtShare = env.decode(&self.codec).map_err(|e| e.to_string())?;
                let (reply, work) =
                    serve_pixel_share(&mut self.store, &self.map, self.shard, j, &m.table)?;
                let secs = work as f64 * self.profile.per_shared_entry;
                self.stats.shares_merged += 1;
                self.stats.entries_improved += reply.pixels.len() as u64;
                self.stats.busy_s += secs;
                out.push(Action::Compute {
                    seconds: secs,
                    activity: Activity::Share,
                });
                let a = Action::send(
                    &self.codec,
                    NodeId::from(j),
                    &ErtReply {
                        table: reply.encode(),
                    },
                )
                .map_err(|e| format!("encoding a reply to node {j}: {e}"))?;
                out.push(a);
                Ok(())
            }
            MessageKind::Control if j == self.nodes => {
                match env
                    .decode::<Control>(&self.codec)
                    .map_err(|e| e.to_string())?
                {
                    Control::Finish => {
                        self.stopped = true;
                        out.push(Action::Stop);
                        Ok(())
                    }
                    other => Err(format!("unexpected {other:?} from the manager")),
                }
            }
            other => Err(format!("unexpected {other} message from rank {j}")),
        }
    }
}

impl Actor for ShardActor {
    fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
        let mut out = Vec::new();
        if self.stopped {
            return out;
        }
        if let Event::Message(env) = event {
            if let Err(e) = self.on_message(env, &mut out) {
                let e = format!("manager shard {}: {e}", self.shard);
                if self.stats.error.is_none() {
                    self.stats.error = Some(e);
                }
                // The manager ends phase 1; this shard stops on its Finish.
                if let Ok(a) = Action::send(&self.codec, NodeId::from(self.nodes), &Control::Abort)
                {
                    out.push(a);
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::pixel_share::NOT_REACHED;
    use proptest::prelude::*;

    fn share(p: &[(u32, Vec<u16>)]) -> Vec<u8> {
        PixelLevels {
            width: 40,
            height: 36,
            levels: 2,
            footprint: [0, 39, 0, 35],
            pixels: p.to_vec(),
        }
        .encode()
    }

    proptest! {
        /// Splitting every share by shard and serving the parts at `K`
        /// shards gives every pixel the certified depth one manager gives
        /// it, and every node receives, over its replies from all shards,
        /// exactly the final depths of the pixels that changed.
        #[test]
        fn shards_certify_what_one_manager_certifies(
            k in 1usize..6,
            shares in proptest::collection::vec(
                (0usize..3, proptest::collection::btree_map(0u32..1440, proptest::collection::vec(0u16..60, 2), 0..30)),
                1..20,
            ),
        ) {
            let map = ShardMap::new(40, 36, k).unwrap();
            let mut one = PixelStore::new(40, 36, 2, 3);
            let mut parts: Vec<PixelStore> = (0..k).map(|_| PixelStore::new(40, 36, 2, 3)).collect();
            let mut seen = vec![vec![NOT_REACHED; 1440]; 3];
            for (j, px) in shares {
                let px: Vec<(u32, Vec<u16>)> = px.into_iter().map(|(p, mut c)| { c.sort_unstable(); (p, c) }).collect();
                serve_pixel_share(&mut one, &ShardMap::single(), 0, j, &share(&px)).unwrap();
                for (s, store) in parts.iter_mut().enumerate() {
                    let mine: Vec<_> = px.iter().filter(|(p, _)| map.shard_of_pixel(*p, 40) == s).cloned().collect();
                    let (r, _) = serve_pixel_share(store, &map, s, j, &share(&mine)).unwrap();
                    for (p, c) in r.pixels {
                        prop_assert_eq!(map.shard_of_pixel(p, 40), s);
                        prop_assert!(c < seen[j][p as usize]);
                        seen[j][p as usize] = c;
                    }
                }
            }
            for p in 0..1440u32 {
                let s = map.shard_of_pixel(p, 40);
                prop_assert_eq!(parts[s].certified()[p as usize], one.certified()[p as usize]);
            }
        }
    }

    #[test]
    fn a_pixel_of_another_shard_is_an_error() {
        let map = ShardMap::new(40, 36, 4).unwrap();
        let mut store = PixelStore::new(40, 36, 2, 3);
        // Pixel (20, 0) is in tile (1, 0): shard 1.
        assert_eq!(map.shard_of_pixel(20, 40), 1);
        let e = serve_pixel_share(&mut store, &map, 0, 2, &share(&[(20, vec![3, 4])])).unwrap_err();
        assert!(e.contains("belongs to manager shard 1, not 0"), "{e}");
        assert!(serve_pixel_share(&mut store, &map, 1, 2, &share(&[(20, vec![3, 4])])).is_ok());
        assert!(serve_pixel_share(&mut store, &map, 1, 2, &[1, 2, 3]).is_err());
    }

    /// A shard stops on the manager's Finish and reports a bad message to
    /// the manager with Abort instead of panicking.
    #[test]
    fn shard_actor_aborts_on_bad_messages_and_stops_on_finish() {
        let codec = Codec::default();
        let map = ShardMap::new(40, 36, 2).unwrap();
        let profile = CostProfile::named("pentium4").unwrap();
        let mut a = ShardActor::new(1, map, 3, (40, 36, 2), profile, codec);
        let env = |from: usize, kind: MessageKind, payload: Vec<u8>| {
            Event::Message(Envelope {
                from: NodeId::from(from),
                to: NodeId::from(4),
                kind,
                payload,
            })
        };
        let share_bytes = codec
            .encode(&ErtShare {
                remaining: 0,
                front: 0.0,
                help: false,
                table: vec![9, 9],
            })
            .unwrap();
        let out = a.handle(0.0, env(0, MessageKind::ErtShare, share_bytes));
        assert!(a.stats().error.is_some());
        assert!(matches!(out.as_slice(), [Action::Send { to, .. }] if to.index() == 3));
        let fin = codec.encode(&Control::Finish).unwrap();
        let out = a.handle(0.0, env(3, MessageKind::Control, fin));
        assert!(matches!(out.as_slice(), [Action::Stop]));
        assert!(a
            .handle(0.0, env(0, MessageKind::ErtShare, vec![]))
            .is_empty());
    }
}
