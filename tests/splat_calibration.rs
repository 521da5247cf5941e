//! The splat part of `pvrsim calibrate` predicts a frame it was not fitted
//! on: calibrate on the built-in hydrogen frames, then model a hydrogen
//! frame of another grid size, image size and TF threshold and compare it
//! with its measured CPU time. The band is generous (0.5x-2x): the machine
//! is shared and noisy, and this checks the model's shape, not the host.
//! The measured time is the fastest of several renders (the host only adds
//! to a CPU time), and the whole check is retried once when it misses.

use pvrsim::bench::calibrate::Timer;
use pvrsim::bench::calibrate_splat::{fit, hydrogen_input, measure, one_thread_pool, render_in};
use pvrsim::node::cost::CostProfile;

fn ratio() -> (f64, f64, f64) {
    let f = fit(&measure(3, Timer::Cpu).unwrap()).unwrap();
    let p = CostProfile {
        per_splat_voxel: f.per_splat_voxel,
        per_splat: f.per_splat,
        per_splat_piece: f.per_splat_piece,
        per_splat_pixel: f.per_splat_pixel,
        ..Default::default()
    };
    // Not a calibration frame: 80^3 (calibration: 32, 64, 96), 192 px
    // (128, 256), threshold 0.2 (0.02, 0.1, 0.4).
    let input = hydrogen_input(80, 192, 0.2).unwrap();
    let pool = one_thread_pool().unwrap();
    let mut measured = f64::INFINITY;
    let mut modelled = 0.0;
    for _ in 0..5 {
        let st = render_in(&pool, &input).unwrap();
        measured = measured.min(1e-3 * (st.order_cpu_ms + st.splat_cpu_ms));
        modelled = p.splat_time(&st);
    }
    (modelled / measured, modelled, measured)
}

#[test]
fn calibrated_splat_costs_predict_another_frame() {
    let (mut r, mut m, mut t) = ratio();
    if !(0.5..=2.0).contains(&r) {
        eprintln!("first try: modelled {m:.4} s, measured {t:.4} s (ratio {r:.2}); retrying");
        (r, m, t) = ratio();
    }
    assert!(
        (0.5..=2.0).contains(&r),
        "modelled {m:.4} s, measured {t:.4} s, ratio {r:.2} outside 0.5-2"
    );
}
