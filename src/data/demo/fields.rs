//! The vertex fields: `velocity`, `speed` and `pressure`.

use super::*;

/// `velocity`, `speed` and `pressure` at the vertices.
pub(super) fn flow_fields(
    mesh: &TetMesh,
    geo: &Geometry,
    on_boundary: &[bool],
    h: f64,
) -> Vec<Field> {
    let samples: Vec<(V3, f64, f64)> = mesh
        .points
        .par_iter()
        .map(|&p| geo.flow_at(p, 0.1 * h))
        .collect();
    let mut velocity = Vec::with_capacity(3 * samples.len());
    let mut speed = Vec::with_capacity(samples.len());
    let mut pressure = Vec::with_capacity(samples.len());
    for (i, (v, s, pr)) in samples.into_iter().enumerate() {
        velocity.extend_from_slice(&v);
        speed.push(if on_boundary[i] { 0.0 } else { s });
        pressure.push(pr);
    }
    vec![
        Field {
            name: "velocity".into(),
            components: 3,
            values: velocity,
        },
        Field {
            name: "speed".into(),
            components: 1,
            values: speed,
        },
        Field {
            name: "pressure".into(),
            components: 1,
            values: pressure,
        },
    ]
}
