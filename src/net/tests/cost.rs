//! The network cost model against its formulas.

use crate::net::{NetState, NetworkModel, NodeId};

/// 1 MB/s, 10 us latency, no framing: easy numbers.
fn simple() -> NetworkModel {
    NetworkModel {
        name: "test".into(),
        latency_s: 10e-6,
        bandwidth_bytes_per_s: Some(1e6),
        ..NetworkModel::ideal()
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1.0)
}

#[test]
fn one_message_costs_latency_plus_bytes_over_bandwidth_plus_overhead() {
    let m = NetworkModel {
        overhead_s: 3e-6,
        header_bytes: 24,
        ..simple()
    };
    let mut s = NetState::new(2);
    let tr = m.transfer(&mut s, NodeId(0), NodeId(1), 1000, 0.5).unwrap();
    assert!(close(tr.arrival, 0.5 + 3e-6 + 10e-6 + 1024.0 / 1e6));
    assert!(close(tr.arrival, m.uncontended_arrival(0.5, 1000)));
    assert_eq!(tr.wire_bytes, 1024);
}

#[test]
fn framing_adds_overhead_per_frame() {
    let gbe = NetworkModel::from_name("gbe").unwrap();
    // 24-byte envelope; 10,000 + 24 bytes need ceil(10024 / 1448) = 7 frames.
    assert_eq!(gbe.wire_bytes(10_000), 10_024 + 7 * 90);
    // An empty message is still one frame.
    assert_eq!(gbe.wire_bytes(0), 24 + 90);
    // Large-message goodput is 941.5 Mb/s (iperf's familiar 941).
    let b = 1448 * 1000 - 24;
    let goodput = (b + 24) as f64 * 8.0 / gbe.wire_time(b);
    assert!((goodput / 1e6 - 941.48).abs() < 0.01, "{goodput}");
}

#[test]
fn two_messages_from_one_sender_serialise() {
    let m = simple();
    let mut s = NetState::new(3);
    let a = m.transfer(&mut s, NodeId(0), NodeId(1), 1000, 0.0).unwrap();
    let b = m.transfer(&mut s, NodeId(0), NodeId(2), 1000, 0.0).unwrap();
    assert!(close(a.arrival, 10e-6 + 1e-3));
    assert!(close(b.send_start, 1e-3));
    assert!(close(b.arrival, 10e-6 + 2e-3));
}

#[test]
fn many_senders_to_one_receiver_are_limited_by_its_ingress() {
    let m = simple();
    let n = 8;
    let mut s = NetState::new(n + 1);
    let mut last = 0.0f64;
    for i in 1..=n {
        let tr = m
            .transfer(&mut s, NodeId::from(i), NodeId(0), 1000, 0.0)
            .unwrap();
        // Every sender's own NIC is free: all start at once...
        assert_eq!(tr.send_start, 0.0);
        last = last.max(tr.arrival);
    }
    // ...but the receiver takes them one after another.
    assert!(close(last, 10e-6 + n as f64 * 1e-3));
}

#[test]
fn disjoint_pairs_do_not_interfere_without_a_bisection_limit() {
    let m = simple();
    let mut s = NetState::new(16);
    for i in 0..8 {
        let tr = m
            .transfer(&mut s, NodeId(i), NodeId(i + 8), 1000, 0.0)
            .unwrap();
        assert!(close(tr.arrival, 10e-6 + 1e-3));
    }
}

#[test]
fn bisection_limit_caps_the_aggregate() {
    // Switch passes 2 MB/s in total; 8 disjoint pairs each send 1000 bytes.
    let m = NetworkModel {
        bisection_bytes_per_s: Some(2e6),
        ..simple()
    };
    let mut s = NetState::new(16);
    let mut last = 0.0f64;
    for i in 0..8 {
        let tr = m
            .transfer(&mut s, NodeId(i), NodeId(i + 8), 1000, 0.0)
            .unwrap();
        last = last.max(tr.arrival);
    }
    // 8000 bytes through 2 MB/s take at least 4 ms.
    assert!(last >= 10e-6 + 8000.0 / 2e6 - 1e-15, "{last}");
    // And no single message is slower than its queue position allows:
    // the last starts at 3.5 ms on the switch and needs 1 ms on its links.
    assert!(close(last, 10e-6 + 3.5e-3 + 1e-3));
}

#[test]
fn self_messages_are_free() {
    let m = simple();
    let mut s = NetState::new(2);
    let tr = m
        .transfer(&mut s, NodeId(1), NodeId(1), 1 << 20, 2.0)
        .unwrap();
    assert_eq!(tr.arrival, 2.0);
    // And they do not occupy the NIC.
    let tr = m.transfer(&mut s, NodeId(1), NodeId(0), 1000, 2.0).unwrap();
    assert_eq!(tr.send_start, 2.0);
}

#[test]
fn bad_ranks_are_errors() {
    let mut s = NetState::new(2);
    assert!(simple()
        .transfer(&mut s, NodeId(0), NodeId(5), 1, 0.0)
        .is_err());
}

#[test]
fn presets_load_validate_and_display() {
    for name in NetworkModel::preset_names() {
        let m = NetworkModel::from_name(name).unwrap();
        assert_eq!(m.name, name);
        assert!(!m.description.is_empty());
        assert!(m.to_string().starts_with(name));
    }
    let gbe = NetworkModel::from_name("gbe").unwrap();
    assert_eq!(gbe.latency_s, 50e-6);
    assert_eq!(gbe.bandwidth_bytes_per_s, Some(125e6));
    assert_eq!(
        NetworkModel::from_name("ideal").unwrap(),
        NetworkModel {
            description: NetworkModel::from_name("ideal").unwrap().description,
            ..NetworkModel::ideal()
        }
    );
    let err = NetworkModel::from_name("token-ring")
        .unwrap_err()
        .to_string();
    assert!(err.contains("gbe") && err.contains("token-ring"), "{err}");
}

#[test]
fn config_files_on_disk_match_presets() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/network");
    for name in NetworkModel::preset_names() {
        let m = NetworkModel::load(&dir.join(format!("{name}.toml"))).unwrap();
        assert_eq!(m, NetworkModel::from_name(name).unwrap());
    }
}

#[test]
fn user_models_are_validated() {
    let ok = "name = \"mine\"\nlatency_s = 1e-5\nbandwidth_bytes_per_s = 1e9\nbisection_bytes_per_s = 4e9\n";
    let m = NetworkModel::from_toml_str(ok).unwrap();
    assert_eq!(m.bisection_bytes_per_s, Some(4e9));
    for bad in [
        "name = \"x\"\nlatency_s = -1.0\n",
        "name = \"x\"\nlatency_s = 0.0\nbandwidth_bytes_per_s = 0.0\n",
        "name = \"x\"\nlatency_s = nan\n",
        "name = \"x\"\nlatency_s = 0.0\nframe_payload_bytes = 0\n",
        "name = \"x\"\nlatency_s = 0.0\nbandwdith = 3.0\n",
    ] {
        assert!(NetworkModel::from_toml_str(bad).is_err(), "{bad}");
    }
}

#[test]
fn transfers_are_deterministic() {
    let m = NetworkModel::from_name("gbe").unwrap();
    let run = || {
        let mut s = NetState::new(9);
        (0..200u32)
            .map(|i| {
                m.transfer(
                    &mut s,
                    NodeId(i % 9),
                    NodeId((i * 7 + 3) % 9),
                    u64::from(i) * 997,
                    f64::from(i) * 1e-5,
                )
                .unwrap()
                .arrival
                .to_bits()
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}
