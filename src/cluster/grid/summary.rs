//! The grid report as text for the terminal ([`summary`]).

use super::GridReport;
use crate::cluster::ClockKind;

/// A one-paragraph summary for the terminal.
pub fn summary(r: &GridReport) -> String {
    let mut s = format!(
        "grid cluster: {} node(s){}, {}^3 bricks, {} / {} / {}\n\
         frame {:.4} s = render {:.4} s + composite {:.4} s; phase-2 bytes {} (codec ratio {:.3})\n\
         renderer {:?}: size ratio {:.3}, preprocessing {:.3} s; bricks over texture memory: {}\n",
        r.n_nodes,
        if r.master { " + master" } else { "" },
        r.subvolumes,
        r.compositor,
        r.codec,
        match r.clock {
            // Times are measured on this host: no network model is used.
            ClockKind::Wall => "wall clock (times measured on this host)".to_string(),
            ClockKind::Virtual => format!("{} network model, virtual clock", r.network),
        },
        r.frame_s,
        r.render_s,
        r.composite_s,
        r.bytes_total,
        r.codec_ratio,
        r.renderer,
        r.size_ratio,
        r.prepare_s,
        r.oversized_bricks
    );
    for n in &r.nodes {
        s.push_str(&format!(
            "  rank {:>2}: bricks {:?} render {:.4} s (fill {:.4}, draw set-up {:.4} for {} textures, upload {:.4} + paging {:.4} for {} B) sent {} B\n",
            n.stats.rank,
            n.stats.bricks,
            n.render_end_s,
            n.stats.device.fill_s,
            n.stats.device.setup_s,
            n.stats.device.textures,
            n.stats.device.upload_s,
            n.stats.device.paging_s,
            n.stats.device.uploaded_bytes,
            n.bytes_sent
        ));
    }
    s
}
