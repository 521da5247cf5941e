//! The channel transport, selective receive and the metering wrapper.

use crate::net::{
    ChannelNetwork, Codec, Mailbox, Message, MessageKind, Metered, NetError, NodeId, Transport,
};

#[derive(serde::Serialize, serde::Deserialize, Debug, PartialEq)]
struct Hello(u32);
impl Message for Hello {
    const KIND: MessageKind = MessageKind::Control;
}

#[test]
fn channel_delivers_in_order_per_pair() {
    let net = ChannelNetwork::new(3);
    assert_eq!(net[2].rank(), NodeId(2));
    assert_eq!(net[0].size(), 3);
    for i in 0..10u8 {
        net[1]
            .send(NodeId(0), MessageKind::Control, vec![i])
            .unwrap();
    }
    for i in 0..10u8 {
        let e = net[0].recv().unwrap();
        assert_eq!((e.from, e.to, e.payload), (NodeId(1), NodeId(0), vec![i]));
    }
    assert_eq!(net[0].try_recv().unwrap(), None);
}

#[test]
fn bad_destination_is_an_error() {
    let net = ChannelNetwork::new(2);
    assert!(matches!(
        net[0].send(NodeId(2), MessageKind::Control, vec![]),
        Err(NetError::NoSuchRank { .. })
    ));
}

#[test]
fn typed_send_and_threads() {
    let net = ChannelNetwork::new(2);
    let codec = Codec::default();
    std::thread::scope(|s| {
        s.spawn(|| net[1].send_msg(&codec, NodeId(0), &Hello(42)).unwrap());
        let e = net[0]
            .recv_timeout(std::time::Duration::from_secs(10))
            .unwrap()
            .unwrap();
        assert_eq!(e.decode::<Hello>(&codec).unwrap(), Hello(42));
    });
}

#[test]
fn mailbox_exchange() {
    let net = ChannelNetwork::new(2);
    std::thread::scope(|s| {
        s.spawn(|| {
            let mut mb = Mailbox::new(&net[1]);
            let e = mb.sendrecv(NodeId(0), MessageKind::Image, vec![1]).unwrap();
            assert_eq!(e.payload, vec![0]);
        });
        net[0]
            .send(NodeId(1), MessageKind::Control, vec![9])
            .unwrap();
        let mut mb = Mailbox::new(&net[0]);
        let e = mb.sendrecv(NodeId(1), MessageKind::Image, vec![0]).unwrap();
        assert_eq!(e.payload, vec![1]);
    });
}

#[test]
fn metered_counts_per_kind_and_destination() {
    let net = ChannelNetwork::new(3);
    let mut it = net.into_iter();
    let (a, b, c) = (it.next().unwrap(), it.next().unwrap(), it.next().unwrap());
    let a = Metered::new(a);
    a.send(NodeId(1), MessageKind::ErtShare, vec![0; 100])
        .unwrap();
    a.send(NodeId(2), MessageKind::ErtShare, vec![0; 50])
        .unwrap();
    a.send(NodeId(2), MessageKind::Image, vec![0; 7]).unwrap();
    b.send(NodeId(0), MessageKind::ErtReply, vec![0; 30])
        .unwrap();
    assert_eq!(a.recv().unwrap().kind, MessageKind::ErtReply);
    assert_eq!(a.try_recv().unwrap(), None);
    let s = a.stats();
    assert_eq!(s.sent_by_kind[&MessageKind::ErtShare].messages, 2);
    assert_eq!(s.sent_by_kind[&MessageKind::ErtShare].bytes, 150);
    assert_eq!(s.sent_by_kind[&MessageKind::Image].bytes, 7);
    assert_eq!(s.sent_by_dest[1].bytes, 100);
    assert_eq!(s.sent_by_dest[2].bytes, 57);
    assert_eq!(s.sent_by_dest[2].messages, 2);
    assert_eq!(s.recv_by_kind[&MessageKind::ErtReply].bytes, 30);
    assert_eq!(s.total_sent().bytes, 157);
    // Serialisable for reports.
    let json = serde_json::to_string(&s).unwrap();
    assert!(json.contains("ErtShare"), "{json}");
    drop(c);
}
