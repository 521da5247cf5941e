//! Max-abs and RMSE (RGB, in 1/255) between two PNGs of the same size, and
//! where the largest difference sits:
//!
//! ```text
//! cargo run --release --example png_diff -- A.png B.png
//! ```

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(args.len() == 2, "usage: png_diff A.png B.png");
    let a = image::open(&args[0])?.to_rgba8();
    let b = image::open(&args[1])?.to_rgba8();
    anyhow::ensure!(a.dimensions() == b.dimensions(), "sizes differ");
    let (mut max, mut sum, mut n, mut at, mut over1) = (0u8, 0f64, 0u64, (0, 0), 0u64);
    for (x, y, p) in a.enumerate_pixels() {
        let q = b.get_pixel(x, y);
        let mut m = 0u8;
        for c in 0..3 {
            let d = p[c].abs_diff(q[c]);
            sum += f64::from(d) * f64::from(d);
            n += 1;
            m = m.max(d);
        }
        over1 += u64::from(m > 1);
        if m > max {
            max = m;
            at = (x, y);
        }
    }
    println!(
        "max {max}/255 at {at:?} ({:?} vs {:?}), RMSE {:.3}/255, pixels > 1/255: {over1}",
        a.get_pixel(at.0, at.1).0,
        b.get_pixel(at.0, at.1).0,
        (sum / n as f64).sqrt()
    );
    Ok(())
}
