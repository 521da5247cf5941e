//! The validation of `cluster`'s and `render`'s options ([`Validate`] for
//! [`ClusterArgs`] and [`RenderArgs`]: ranges, then the table), and the one
//! table of options that only matter with another setting: an ERT
//! structure, sharing, a transport, a clock, a renderer, a series. Each row
//! says which option, which setting it needs, and what happens when it is
//! given without that setting: refused (an error that says how to turn the
//! setting on) or warned about (the README's "`warning:` ... has no
//! effect"), never ignored in silence.
//!
//! The tests walk every row with the arguments it names (the option
//! without its setting: refused or warned; with it: nothing said about it).

use crate::cluster::ClockKind;
use crate::job::cluster::{ClusterArgs, Sharing};
use crate::job::render::{RenderArgs, RendererKind};
use crate::job::validate::{self, at_least, needs, Checks, Validate};
use crate::node::DataMode;
use crate::render::cell::ert::ErtStructure;

/// The kind of setting an option depends on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// Early ray termination on (`--ert < 1`).
    Ert,
    /// ERT tables shared through the manager or by overlap.
    Sharing,
    /// The ERT structure (`--ert-structure`, `--paper`).
    Structure,
    /// A transport (`--transport`).
    Transport,
    /// The clock (`--clock`).
    Clock,
    /// The renderer (`--renderer`).
    Renderer,
    /// A frame series (`--frames`, `--series`).
    Series,
}

/// What happens to an option given without its setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// An error: `OPTION needs WHEN`.
    Refuse,
    /// A warning: `OPTION has no effect: WHEN`.
    Warn,
}

/// One option that only matters with another setting.
pub struct Rule<A> {
    /// The option as the user types it (the messages start with it).
    pub option: &'static str,
    /// The option's value as given, shown after its name (`--network gbe`).
    pub value: Option<fn(&A) -> String>,
    /// The kind of setting it needs.
    pub setting: Setting,
    /// Refused or warned about.
    pub effect: Effect,
    /// Refuse: what it needs and how to get it. Warn: why it does nothing.
    pub when: &'static str,
    /// Whether the option was given.
    pub given: fn(&A) -> bool,
    /// Whether its setting holds.
    pub holds: fn(&A) -> bool,
    /// Arguments (after `pvrsim COMMAND SCENE`) giving the option without
    /// its setting (the test walks them).
    pub without: &'static [&'static str],
    /// Arguments giving the option with its setting.
    pub with: &'static [&'static str],
}

impl<A> Rule<A> {
    /// The option as the messages name it (with its value where it has one).
    pub fn shown(&self, a: &A) -> String {
        match self.value {
            Some(v) => format!("{} {}", self.option, v(a)),
            None => self.option.to_string(),
        }
    }
}

/// Applies `rules` to `a`: the first refusal is the error; warnings go to `c`.
pub fn apply<A>(rules: &[Rule<A>], a: &A, c: &mut Checks) -> anyhow::Result<()> {
    for r in rules {
        let given = (r.given)(a);
        if !given || (r.holds)(a) {
            continue;
        }
        match r.effect {
            Effect::Refuse => needs(&r.shown(a), given, false, r.when)?,
            Effect::Warn => c.ignored(&r.shown(a), r.when),
        }
    }
    Ok(())
}

const ERT_HOW: &str = "early ray termination: give --ert < 1 (e.g. 0.9); --ert 1 turns it off";

fn cluster_ert_on(a: &ClusterArgs) -> bool {
    a.ert.threshold < 1.0
}

fn cluster_sharing(a: &ClusterArgs) -> Sharing {
    if a.share {
        Sharing::Manager
    } else {
        a.sharing
    }
}

fn manager_sharing(a: &ClusterArgs) -> bool {
    cluster_ert_on(a) && cluster_sharing(a) == Sharing::Manager
}

fn wall_clock(a: &ClusterArgs) -> bool {
    use crate::job::args::transport::TransportKind;
    a.clock == Some(ClockKind::Wall) || a.net.transport == Some(TransportKind::Threads)
}

/// `cluster`'s options that only matter with another setting.
pub const CLUSTER: &[Rule<ClusterArgs>] = &[
    Rule {
        option: "--share",
        value: None,
        setting: Setting::Ert,
        effect: Effect::Refuse,
        when: ERT_HOW,
        given: |a| a.share,
        holds: cluster_ert_on,
        without: &["--share", "--ert", "1"],
        with: &["--share", "--ert", "0.9"],
    },
    Rule {
        option: "--sharing manager|overlap",
        value: None,
        setting: Setting::Ert,
        effect: Effect::Refuse,
        when: ERT_HOW,
        given: |a| a.sharing != Sharing::Off,
        holds: cluster_ert_on,
        without: &["--sharing", "overlap", "--ert", "1"],
        with: &["--sharing", "overlap", "--ert", "0.9"],
    },
    Rule {
        option: "--schedule-waves",
        value: None,
        setting: Setting::Sharing,
        effect: Effect::Refuse,
        when: "replicated data (the default; not --paper or --data partitioned) and sharing through the manager: add --share and --ert < 1",
        given: |a| a.ert_mode.schedule_waves.is_some_and(|w| w > 1),
        holds: |a| {
            manager_sharing(a) && !a.ert_mode.paper && a.data != Some(DataMode::Partitioned)
        },
        without: &["--schedule-waves", "4", "--ert", "0.9"],
        with: &["--schedule-waves", "4", "--ert", "0.9", "--share"],
    },
    Rule {
        option: "--manager-shards",
        value: None,
        setting: Setting::Sharing,
        effect: Effect::Refuse,
        when: "per-pixel sharing through the manager: add --share (or --sharing manager) and --ert < 1",
        given: |a| a.ert_mode.manager_shards.is_some(),
        holds: manager_sharing,
        without: &["--manager-shards", "2", "--ert", "0.9"],
        with: &["--manager-shards", "2", "--ert", "0.9", "--share"],
    },
    Rule {
        option: "--share-levels/--share-sub (level sharing)",
        value: None,
        setting: Setting::Sharing,
        effect: Effect::Refuse,
        when: "sharing through the manager: add --share (or --sharing manager) and --ert < 1",
        given: |a| a.share_levels.is_some_and(|l| l > 1) || a.share_sub > 1,
        holds: manager_sharing,
        without: &["--share-levels", "4", "--ert", "0.9"],
        with: &["--share-levels", "4", "--ert", "0.9", "--share"],
    },
    Rule {
        option: "--share-sub",
        value: Some(|a| a.share_sub.to_string()),
        setting: Setting::Structure,
        effect: Effect::Warn,
        when: "it splits the flat table's entries into blocks; the pyramid structure (the default) shares per-pixel levels (give --ert-structure flat for block levels)",
        given: |a| a.share_sub > 1 && manager_sharing(a) && !a.ert_mode.paper,
        holds: |a| a.ert_mode.ert_structure == Some(ErtStructure::Flat),
        without: &["--share-sub", "3", "--share", "--ert", "0.9"],
        with: &[
            "--share-sub",
            "3",
            "--share",
            "--ert",
            "0.9",
            "--ert-structure",
            "flat",
        ],
    },
    Rule {
        option: "--share-levels/--share-sub",
        value: None,
        setting: Setting::Structure,
        effect: Effect::Warn,
        when: "--paper shares whole entries of the flat table (one level)",
        given: |a| a.ert_mode.paper && (a.share_levels.is_some() || a.share_sub > 1),
        holds: |a| !a.ert_mode.paper,
        without: &["--paper", "--share-levels", "4", "--share", "--ert", "0.9"],
        with: &["--share-levels", "4", "--share", "--ert", "0.9"],
    },
    Rule {
        option: "--ert-structure",
        value: None,
        setting: Setting::Structure,
        effect: Effect::Warn,
        when: "--paper tests the flat table (the paper's structure)",
        given: |a| a.ert_mode.paper && a.ert_mode.ert_structure == Some(ErtStructure::Pyramid),
        holds: |a| !a.ert_mode.paper,
        without: &["--paper", "--ert-structure", "pyramid"],
        with: &["--ert-structure", "pyramid"],
    },
    Rule {
        option: "--release-block",
        value: Some(|a| a.ert_mode.release_block.to_string()),
        setting: Setting::Structure,
        effect: Effect::Warn,
        when: "release ordering runs with the pyramid structure and sharing through the manager (not --ert-structure flat or --paper; add --share and --ert < 1)",
        given: |a| a.ert_mode.release_block > 0,
        holds: |a| {
            manager_sharing(a)
                && !a.ert_mode.paper
                && a.ert_mode.ert_structure != Some(ErtStructure::Flat)
        },
        without: &["--release-block", "16", "--share", "--ert", "0.9", "--ert-structure", "flat"],
        with: &["--release-block", "16", "--share", "--ert", "0.9"],
    },
    Rule {
        option: "--data replicated",
        value: None,
        setting: Setting::Structure,
        effect: Effect::Warn,
        when: "--paper moves cells with their vertices, as the paper's nodes did",
        given: |a| a.ert_mode.paper && a.data == Some(DataMode::Replicated),
        holds: |a| !a.ert_mode.paper,
        without: &["--paper", "--data", "replicated"],
        with: &["--data", "replicated"],
    },
    Rule {
        option: "--workers/--hostfile/--token-file",
        value: None,
        setting: Setting::Transport,
        effect: Effect::Refuse,
        when: "--transport tcp",
        given: |a| {
            !a.net.workers.is_empty() || a.net.hostfile.is_some() || a.net.token_file.is_some()
        },
        holds: |a| a.net.transport == Some(crate::job::args::transport::TransportKind::Tcp),
        without: &["--workers", "a:1,b:2", "--nodes", "2"],
        with: &["--workers", "a:1,b:2", "--nodes", "2", "--transport", "tcp"],
    },
    Rule {
        option: "--network",
        value: Some(|a| a.network.clone().unwrap_or_default()),
        setting: Setting::Clock,
        effect: Effect::Warn,
        when: "--clock wall measures times on this host; the network and cost models only set times on the virtual clock",
        given: |a| a.network.is_some() && wall_clock(a),
        holds: |a| !wall_clock(a),
        without: &["--network", "gbe", "--clock", "wall", "--nodes", "2"],
        with: &["--network", "gbe", "--nodes", "2"],
    },
    Rule {
        option: "--profile",
        value: Some(|a| a.profile.clone().unwrap_or_default()),
        setting: Setting::Clock,
        effect: Effect::Warn,
        when: "--clock wall measures times on this host; the network and cost models only set times on the virtual clock",
        given: |a| a.profile.is_some() && wall_clock(a),
        holds: |a| !wall_clock(a),
        without: &["--profile", "pentium4", "--clock", "wall", "--nodes", "2"],
        with: &["--profile", "pentium4", "--nodes", "2"],
    },
    Rule {
        option: "--coherence",
        value: None,
        setting: Setting::Series,
        effect: Effect::Warn,
        when: "it carries placement from frame to frame of a series (--frames or --series)",
        given: |a| a.series.coherence.is_some(),
        holds: |a| a.series.is_series(),
        without: &["--coherence", "placement"],
        with: &["--coherence", "placement", "--frames", "2"],
    },
];

fn reference(a: &RenderArgs) -> bool {
    a.renderer == Some(RendererKind::Reference)
}

const REFERENCE_WHY: &str = "the reference renderer has no ERT, tiles or segment lists";
const ERT_OFF_WHY: &str = "ERT is off (--ert 1); give --ert < 1, e.g. 0.9";

/// `render`'s options that only matter with another setting.
pub const RENDER: &[Rule<RenderArgs>] = &[
    Rule {
        option: "--ert-table",
        value: None,
        setting: Setting::Renderer,
        effect: Effect::Warn,
        when: REFERENCE_WHY,
        given: |a| a.ert_table.is_some(),
        holds: |a| !reference(a),
        without: &["--ert-table", "20", "--renderer", "reference"],
        with: &["--ert-table", "20"],
    },
    Rule {
        option: "--ert-entry-px",
        value: None,
        setting: Setting::Renderer,
        effect: Effect::Warn,
        when: REFERENCE_WHY,
        given: |a| a.ert_entry_px.is_some(),
        holds: |a| !reference(a),
        without: &["--ert-entry-px", "8", "--renderer", "reference"],
        with: &["--ert-entry-px", "8"],
    },
    Rule {
        option: "--oracle",
        value: None,
        setting: Setting::Renderer,
        effect: Effect::Warn,
        when: REFERENCE_WHY,
        given: |a| a.oracle,
        holds: |a| !reference(a),
        without: &["--oracle", "--renderer", "reference"],
        with: &["--oracle"],
    },
    Rule {
        option: "--canonical",
        value: None,
        setting: Setting::Renderer,
        effect: Effect::Warn,
        when: REFERENCE_WHY,
        given: |a| a.canonical,
        holds: |a| !reference(a),
        without: &["--canonical", "--renderer", "reference"],
        with: &["--canonical"],
    },
    Rule {
        option: "--no-partial-composition",
        value: None,
        setting: Setting::Renderer,
        effect: Effect::Warn,
        when: REFERENCE_WHY,
        given: |a| a.no_partial_composition,
        holds: |a| !reference(a),
        without: &["--no-partial-composition", "--renderer", "reference"],
        with: &["--no-partial-composition"],
    },
    Rule {
        option: "--compare",
        value: None,
        setting: Setting::Renderer,
        effect: Effect::Warn,
        when: "--renderer reference is the reference itself",
        given: |a| a.compare,
        holds: |a| !reference(a),
        without: &["--compare", "--renderer", "reference"],
        with: &["--compare"],
    },
    // With the reference renderer, the rows above already say why.
    Rule {
        option: "--ert-table",
        value: None,
        setting: Setting::Ert,
        effect: Effect::Warn,
        when: ERT_OFF_WHY,
        given: |a| a.ert_table.is_some() && !reference(a),
        holds: |a| a.ert.threshold < 1.0,
        without: &["--ert-table", "20", "--ert", "1"],
        with: &["--ert-table", "20", "--ert", "0.9"],
    },
    Rule {
        option: "--ert-entry-px",
        value: None,
        setting: Setting::Ert,
        effect: Effect::Warn,
        when: ERT_OFF_WHY,
        given: |a| a.ert_entry_px.is_some() && !reference(a),
        holds: |a| a.ert.threshold < 1.0,
        without: &["--ert-entry-px", "8", "--ert", "1"],
        with: &["--ert-entry-px", "8", "--ert", "0.9"],
    },
];

impl Validate for ClusterArgs {
    type Parsed = crate::job::cluster::ClusterChoices;

    fn validate(&self, c: &mut Checks) -> anyhow::Result<Self::Parsed> {
        let ert = validate::ert_mode(self.ert.threshold)?;
        at_least("--nodes", self.nodes, 1)?;
        at_least("--ert-table", self.ert_table, 1)?;
        at_least("--ert-update", self.ert_update, 1)?;
        at_least("--chunk", self.chunk, 1)?;
        at_least(
            "--schedule-leaf-cells",
            self.ert_mode.schedule_leaf_cells,
            1,
        )?;
        at_least("--min-grant", self.min_grant, 1)?;
        at_least("--progress-every", self.progress_every, 1)?;
        validate::image_size(self.width, self.height)?;
        self.series.check()?;
        apply(CLUSTER, self, c)?;
        check_worker_count(self)?;
        if let Some(t) = self.net.transport {
            anyhow::ensure!(
                self.clock != Some(ClockKind::Virtual),
                "--clock virtual cannot be combined with --transport {}: a real transport runs \
                 on wall time (drop --clock, or drop --transport for the simulation)",
                t.name()
            );
        }
        use crate::job::args::transport::TransportKind;
        if let Some(coh) = self.series.coherence {
            anyhow::ensure!(
                coh == crate::cluster::series::Coherence::Off
                    || matches!(self.net.transport, None | Some(TransportKind::Threads)),
                "--coherence placement runs in this process (the simulated cluster or \
                 --transport threads); worker processes keep the cells the set-up gave them"
            );
        }
        let local = match self.net.transport {
            Some(TransportKind::Threads) => Some("--transport threads"),
            Some(TransportKind::Processes) => Some("--transport processes"),
            None if self.clock == Some(ClockKind::Wall) => Some("--clock wall"),
            _ => None,
        };
        if let Some(how) = local {
            crate::budget::local_nodes("--nodes", self.nodes, how)?;
        }
        Ok(crate::job::cluster::ClusterChoices {
            ert,
            compositing: if self.grid.master {
                // Checked against --compositor and --radix-k with the grid's
                // options (a mesh refuses --master).
                crate::compositor::strategy::Compositing::Master
            } else {
                self.compositing()?
            },
        })
    }
}

/// `--transport tcp`: one worker per node, counted before any work
/// (`--workers` as given, `--hostfile` as read).
fn check_worker_count(a: &ClusterArgs) -> anyhow::Result<()> {
    use crate::job::args::transport::{read_hostfile, TransportKind};
    if a.net.transport != Some(TransportKind::Tcp) {
        return Ok(());
    }
    let (workers, from) = match &a.net.hostfile {
        Some(p) => (
            read_hostfile(p)?.len(),
            format!("--hostfile {} lists", p.display()),
        ),
        None if a.net.workers.is_empty() => return Ok(()),
        None => (a.net.workers.len(), "--workers lists".to_string()),
    };
    anyhow::ensure!(
        workers == a.nodes,
        "--nodes {} needs {}; {from} {workers}",
        a.nodes,
        crate::text::plural(a.nodes, "worker")
    );
    Ok(())
}

impl Validate for RenderArgs {
    type Parsed = crate::job::render::RenderChoices;

    fn validate(&self, c: &mut Checks) -> anyhow::Result<Self::Parsed> {
        let ert = validate::ert_mode(self.ert.threshold)?;
        at_least("--tile", self.tile, 1)?;
        at_least("--ert-update", self.ert_update, 1)?;
        if let Some(d) = self.ert_table {
            at_least("--ert-table", d, 1)?;
        }
        if let Some(n) = self.ert_entry_px {
            at_least("--ert-entry-px", n, 1)?;
        }
        validate::image_size(self.width, self.height)?;
        crate::budget::threads("--threads", self.threads)?;
        crate::budget::slices("--slices", self.slices.unwrap_or(0))?;
        apply(RENDER, self, c)?;
        Ok(crate::job::render::RenderChoices { ert })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::validate::check;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cluster {
        #[command(flatten)]
        a: ClusterArgs,
    }

    #[derive(Debug, Parser)]
    struct Render {
        #[command(flatten)]
        a: RenderArgs,
    }

    fn argv<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        let mut v = vec!["pvrsim", "scene.toml"];
        v.extend_from_slice(extra);
        v
    }

    /// Walks `rules`: given without its setting, each option is refused
    /// or warned about by the command's validation (naming the option);
    /// with its setting, nothing is said about it.
    fn walk<A: Validate>(rules: &[Rule<A>], parse: impl Fn(&[&str]) -> A) {
        for r in rules {
            let a = parse(r.without);
            assert!(
                (r.given)(&a),
                "{}: {:?} does not give it",
                r.option,
                r.without
            );
            assert!(
                !(r.holds)(&a),
                "{}: {:?} holds the setting",
                r.option,
                r.without
            );
            let shown = r.shown(&a);
            match (check(&a), r.effect) {
                (Err(e), Effect::Refuse) => {
                    assert_eq!(e.to_string(), format!("{shown} needs {}", r.when))
                }
                (Ok(w), Effect::Warn) => assert!(
                    w.contains(&format!("{shown} has no effect: {}", r.when)),
                    "{shown}: {w:?}"
                ),
                (got, _) => panic!("{shown} without its setting {:?}: {got:?}", r.setting),
            }
            let a = parse(r.with);
            assert!(
                (r.holds)(&a),
                "{}: {:?} misses the setting",
                r.option,
                r.with
            );
            let w = check(&a).unwrap_or_else(|e| panic!("{} with {:?}: {e}", r.option, r.with));
            assert!(
                !w.iter().any(|w| w.starts_with(r.option)),
                "{}: {w:?}",
                r.option
            );
        }
    }

    #[test]
    fn every_cluster_rule_refuses_or_warns_without_its_setting() {
        walk(CLUSTER, |x| {
            Cluster::try_parse_from(argv(x))
                .unwrap_or_else(|e| panic!("{x:?}: {e}"))
                .a
        });
    }

    #[test]
    fn every_render_rule_warns_without_its_setting() {
        walk(RENDER, |x| {
            Render::try_parse_from(argv(x))
                .unwrap_or_else(|e| panic!("{x:?}: {e}"))
                .a
        });
    }

    #[test]
    fn the_table_covers_every_kind_of_setting() {
        let kinds: Vec<Setting> = CLUSTER
            .iter()
            .map(|r| r.setting)
            .chain(RENDER.iter().map(|r| r.setting))
            .collect();
        for k in [
            Setting::Ert,
            Setting::Sharing,
            Setting::Structure,
            Setting::Transport,
            Setting::Clock,
            Setting::Renderer,
            Setting::Series,
        ] {
            assert!(kinds.contains(&k), "no rule for {k:?}");
        }
    }
}
