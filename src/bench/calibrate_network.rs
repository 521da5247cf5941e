//! `pvrsim calibrate --network`: a ping-pong sweep over a pvrsim TCP link
//! (1 B to 64 MiB by default) fits the cost model's `alpha` (latency) and
//! `beta` (bandwidth) and writes a network profile TOML that `pvrsim
//! cluster --network FILE` reads.
//!
//! One-way time `t(n) = rtt(n) / 2` per payload size `n` (median of the
//! repetitions); `alpha` from the small sizes, `beta` from the large ones
//! (see [`fit`]), in f64.

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

/// Bytes from which a sample is taken as bandwidth-bound.
pub const LARGE_BYTES: u64 = 1 << 20;
/// Bytes up to which a sample is taken as latency-bound.
pub const SMALL_BYTES: u64 = 1 << 10;

/// Fits `t = alpha + n / beta` in two regimes (Hockney's model, as
/// ping-pong benchmarks report it): `alpha` is the mean one-way time of the
/// latency-bound sizes (`n <= SMALL_BYTES`); `beta` is the least-squares
/// slope of `t - alpha` against `n` through the origin over the
/// bandwidth-bound sizes (`n >= LARGE_BYTES`; the largest two if none),
/// `1/beta = sum n (t - alpha) / sum n^2`. Middle sizes ride on socket
/// buffers and fit neither regime, so they are printed but not fitted.
/// Returns `(alpha, beta)`.
pub fn fit(samples: &[Sample]) -> anyhow::Result<(f64, f64)> {
    anyhow::ensure!(samples.len() >= 2, "need at least two sizes to fit");
    for s in samples {
        anyhow::ensure!(
            s.one_way_s.is_finite() && s.one_way_s > 0.0,
            "a non-positive time at {} bytes",
            s.bytes
        );
    }
    let small: Vec<&Sample> = samples.iter().filter(|s| s.bytes <= SMALL_BYTES).collect();
    let small = if small.is_empty() {
        vec![samples
            .iter()
            .min_by_key(|s| s.bytes)
            .unwrap_or(&samples[0])]
    } else {
        small
    };
    let alpha = small.iter().map(|s| s.one_way_s).sum::<f64>() / small.len() as f64;
    let mut large: Vec<&Sample> = samples.iter().filter(|s| s.bytes >= LARGE_BYTES).collect();
    if large.is_empty() {
        let mut by_size: Vec<&Sample> = samples.iter().collect();
        by_size.sort_by_key(|s| s.bytes);
        large = by_size.into_iter().rev().take(2).collect();
    }
    let (mut snn, mut snt) = (0.0f64, 0.0f64);
    for s in &large {
        let n = s.bytes as f64;
        snn += n * n;
        snt += n * (s.one_way_s - alpha);
    }
    anyhow::ensure!(
        snt > 0.0,
        "large messages are not slower than small ones: too few or too noisy samples"
    );
    Ok((alpha, snn / snt))
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
            let program = crate::cluster::remote::spawn::WorkerProgram::this()?;
            let w = LocalWorkers::spawn(&program, 1, &[], Duration::from_secs(30))?;
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
         # One-way time t(n) = rtt/2, median per size; t = latency_s + n / bandwidth_bytes_per_s with\n\
         # latency_s = mean t(n <= 1 KiB), bandwidth from n >= 1 MiB. Samples (bytes, one-way seconds):\n{}\
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
        // alpha absorbs the small sizes' mean n/beta (1.9 us here), which
        // beta's fit then sees as a tiny offset.
        let absorbed = (1.0 + 4.0 + 16.0 + 64.0 + 256.0 + 1024.0) / 6.0 / beta;
        assert!((a - alpha - absorbed).abs() < 1e-12, "{a}");
        assert!((b / beta - 1.0).abs() < 1e-4, "{b}");
    }

    #[test]
    fn one_size_is_not_enough() {
        let s = [Sample {
            bytes: 8,
            one_way_s: 1e-5,
        }];
        assert!(fit(&s).is_err());
        let flat = [
            Sample {
                bytes: 8,
                one_way_s: 1e-5,
            },
            Sample {
                bytes: 1 << 20,
                one_way_s: 1e-5,
            },
        ];
        assert!(fit(&flat).is_err());
    }
}
