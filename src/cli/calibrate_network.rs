//! `pvrsim calibrate --network`: a ping-pong sweep over a pvrsim TCP link
//! (1 B to 64 MiB by default) fits the cost model's `alpha` (latency) and
//! `beta` (bandwidth) and writes a network profile TOML that `pvrsim
//! cluster --network FILE` reads.
//!
//! One-way time `t(n) = rtt(n) / 2` per payload size `n` (median of the
//! repetitions). The fit minimises the *relative* error
//! `sum_i ((alpha + n_i / beta - t_i) / t_i)^2`, linear least squares in
//! `(alpha, 1/beta)` with weights `1 / t_i^2`, in f64, so 1-byte and 64-MiB
//! points both count (plain least squares would ignore the small ones).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use tokio::io::AsyncWriteExt;

use crate::cluster::remote::LocalWorkers;
use crate::net::tcp::frame::{encode_frame, read_frame_async, LinkFrame};
use crate::net::tcp::{self, Role, TcpOptions, Token};
use crate::net::{Codec, Envelope, MessageKind, NodeId};

/// Options of `pvrsim calibrate --network`.
#[derive(Debug, Clone, Args)]
pub struct NetworkCalibrateArgs {
    /// Measure the network instead of the node: ping-pong to a worker.
    #[arg(long = "network")]
    pub network: bool,
    /// The worker to ping (`pvrsim worker` address); default: a worker
    /// process started on loopback.
    #[arg(long, value_name = "HOST:PORT", requires = "network")]
    pub peer: Option<String>,
    /// Token file of that worker (without it: loopback only).
    #[arg(long = "peer-token-file", value_name = "FILE", requires = "network")]
    pub peer_token_file: Option<PathBuf>,
    /// Largest payload, bytes (sizes go 1, 4, 16, ... up to it).
    #[arg(long, value_name = "BYTES", default_value_t = 64 << 20, requires = "network")]
    pub max_bytes: u64,
    /// Where to write the network profile.
    #[arg(
        long = "network-out",
        value_name = "FILE",
        default_value = "configs/network/measured.toml",
        requires = "network"
    )]
    pub network_out: PathBuf,
    /// Profile name written into the file.
    #[arg(
        long = "network-name",
        default_value = "measured",
        requires = "network"
    )]
    pub name: String,
}

/// One size's measurement.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    /// Payload bytes.
    pub bytes: u64,
    /// Median one-way seconds.
    pub one_way_s: f64,
}

/// Fits `t = alpha + n / beta` minimising the relative error; returns
/// `(alpha, beta)`.
pub fn fit(samples: &[Sample]) -> anyhow::Result<(f64, f64)> {
    // Normal equations of min sum w (a + b n - t)^2, w = 1/t^2, b = 1/beta.
    let (mut sw, mut sn, mut snn, mut st, mut snt) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for s in samples {
        anyhow::ensure!(
            s.one_way_s > 0.0,
            "a non-positive time at {} bytes",
            s.bytes
        );
        let w = 1.0 / (s.one_way_s * s.one_way_s);
        let n = s.bytes as f64;
        sw += w;
        sn += w * n;
        snn += w * n * n;
        st += w * s.one_way_s;
        snt += w * n * s.one_way_s;
    }
    let det = sw * snn - sn * sn;
    anyhow::ensure!(det > 0.0, "need at least two distinct sizes to fit");
    let a = (snn * st - sn * snt) / det;
    let b = (sw * snt - sn * st) / det;
    anyhow::ensure!(
        b > 0.0,
        "the fit gives a non-positive time per byte ({b:e} s/B): too few or too noisy samples"
    );
    Ok((a.max(0.0), 1.0 / b))
}

/// Runs the sweep and writes the profile.
pub fn run(a: &NetworkCalibrateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(a.max_bytes >= 16, "--max-bytes must be at least 16");
    anyhow::ensure!(
        a.max_bytes <= crate::net::DEFAULT_MAX_MESSAGE_BYTES,
        "--max-bytes is above the frame limit of {} bytes",
        crate::net::DEFAULT_MAX_MESSAGE_BYTES
    );
    let mut _local = None;
    let (addr, token) = match &a.peer {
        Some(p) => (
            p.clone(),
            match &a.peer_token_file {
                Some(f) => Token::load(f)?,
                None => Token::none(),
            },
        ),
        None => {
            let exe = std::env::current_exe().context("cannot find this program's path")?;
            let w = LocalWorkers::spawn(&exe, 1, &[], Duration::from_secs(30))?;
            let r = (w.addrs[0].clone(), w.token().clone());
            _local = Some(w);
            r
        }
    };
    let samples = sweep(&addr, &token, a.max_bytes)?;
    let (alpha, beta) = fit(&samples)?;
    println!("{:>12} {:>14} {:>14}", "bytes", "one-way (us)", "fit (us)");
    for s in &samples {
        println!(
            "{:>12} {:>14.1} {:>14.1}",
            s.bytes,
            s.one_way_s * 1e6,
            (alpha + s.bytes as f64 / beta) * 1e6
        );
    }
    println!(
        "alpha = {:.1} us, beta = {:.1} MB/s ({:.0} Mbit/s)",
        alpha * 1e6,
        beta / 1e6,
        beta * 8.0 / 1e6
    );
    let toml = format!(
        "# Written by `pvrsim calibrate --network` (ping-pong over a pvrsim TCP link to {addr}).\n\
         # One-way time t(n) = rtt/2, median per size; fit t = latency_s + n / bandwidth_bytes_per_s\n\
         # minimising the relative error. Samples (bytes, one-way seconds):\n{}\
         name = {:?}\n\
         description = \"measured by ping-pong to {addr}\"\n\
         latency_s = {alpha:e}\n\
         bandwidth_bytes_per_s = {beta:e}\n\
         overhead_s = 0.0\n\
         # The pvrsim link frame: tag (1) + header (17).\n\
         header_bytes = 18\n\
         # Framing is inside the fitted bandwidth (measured end to end).\n\
         frame_overhead_bytes = 0\n",
        samples
            .iter()
            .map(|s| format!("#   {:>10} {:e}\n", s.bytes, s.one_way_s))
            .collect::<String>(),
        a.name
    );
    crate::net::NetworkModel::from_toml_str(&toml)
        .context("the written profile does not load back (internal error)")?;
    if let Some(d) = a.network_out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    std::fs::write(&a.network_out, toml)
        .with_context(|| format!("cannot write {}", a.network_out.display()))?;
    println!("wrote {}", a.network_out.display());
    Ok(())
}

/// Ping-pong: sizes 1, 4, 16, ... up to `max`, each repeated until about
/// 0.2 s or 3 times; median round trip / 2.
pub fn sweep(addr: &str, token: &Token, max: u64) -> anyhow::Result<Vec<Sample>> {
    let rt = tcp::runtime()?;
    let codec = Codec::default();
    let opts = TcpOptions::default();
    rt.block_on(async {
        let (mut s, hello) = tcp::connect(addr, token, Role::Probe, 0, &opts).await?;
        anyhow::ensure!(hello.role == Role::Worker, "{addr} is not a pvrsim worker");
        let mut out = Vec::new();
        let mut n = 1u64;
        while n <= max {
            let env = Envelope {
                from: NodeId(0),
                to: NodeId(1),
                kind: MessageKind::Control,
                payload: vec![0xa5; n as usize],
            };
            let frame = encode_frame(&codec, &LinkFrame::Data(env))?;
            let mut rtts = Vec::new();
            let t0 = Instant::now();
            // One warm-up round, then measured ones.
            for i in 0..1000 {
                let t = Instant::now();
                s.write_all(&frame).await?;
                match read_frame_async(&mut s, &codec, Some(Duration::from_secs(30))).await? {
                    Some(LinkFrame::Data(e)) if e.payload.len() as u64 == n => {}
                    other => anyhow::bail!("{addr} echoed {other:?} for {n} bytes"),
                }
                if i > 0 {
                    rtts.push(t.elapsed().as_secs_f64());
                }
                if rtts.len() >= 3 && t0.elapsed() > Duration::from_millis(200) {
                    break;
                }
            }
            rtts.sort_by(f64::total_cmp);
            out.push(Sample {
                bytes: n,
                one_way_s: rtts[rtts.len() / 2] / 2.0,
            });
            n *= 4;
        }
        s.write_all(&[crate::net::tcp::frame::TAG_GOODBYE]).await?;
        Ok(out)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_known_line() {
        let (alpha, beta) = (50e-6, 117e6);
        let s: Vec<Sample> = (0..14)
            .map(|k| {
                let n = 4u64.pow(k);
                Sample {
                    bytes: n,
                    one_way_s: alpha + n as f64 / beta,
                }
            })
            .collect();
        let (a, b) = fit(&s).unwrap();
        assert!(
            (a - alpha).abs() < 1e-12 && (b / beta - 1.0).abs() < 1e-9,
            "{a} {b}"
        );
    }

    #[test]
    fn one_size_is_not_enough() {
        let s = [Sample {
            bytes: 8,
            one_way_s: 1e-5,
        }];
        assert!(fit(&s).is_err());
    }
}
