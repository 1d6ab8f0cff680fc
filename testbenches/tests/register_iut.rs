//! The interrupt-driven host of the register IUT (`testbenches::register_iut`): its register accesses
//! do not change what the controller drives on the bus, and every kind of interrupt the protocol
//! scenarios rely on (RI, BEI, ALI, TI) becomes the event the core would report.

use golden::frame::{encode, Field, Frame, Id, DOMINANT};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::protocol_bench::{Iut, LtScript, ProtocolBench, INTEGRATION_BITS};
use testbenches::register_iut::RegisterIut;

fn std_frame(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

/// Idle bits the LT leaves after a frame or an error flag before its next frame.
const GAP_BITS: usize = 25;
/// Script bits of an intermission.
const INTERMISSION_BITS: usize = 3;

/// The traffic of [`traffic`]: the IUT's frame and the LT's frames (received, received, winner of the
/// arbitration).
fn frames() -> (Frame, [Frame; 3]) {
    let mine = std_frame(0x7F0, &[0x01, 0x02]);
    let theirs = [
        std_frame(0x2C5, &[0x81, 0x3C]),
        std_frame(0x0A1, &[0x42]),
        std_frame(0x100, &[0x0F]),
    ];
    (mine, theirs)
}

/// The register IUT (its interrupts serviced, or ignored by the host) receives a frame, detects a
/// stuff error, receives a second frame while its own request comes, loses arbitration at ID.28
/// to the LT's third frame started with its SOF, receives that one and retransmits, acknowledged.
/// Returns the bench played to the end and the script's length.
fn traffic(serviced: bool) -> (ProtocolBench, usize) {
    let (mine, [a, c, d]) = frames();
    let (enc_mine, enc_a, enc_c, enc_d) = (encode(&mine), encode(&a), encode(&c), encode(&d));
    let mut bench = ProtocolBench::new(Iut::Registers);
    if !serviced {
        let iut = bench.iut_id();
        bench
            .engine
            .device_mut::<RegisterIut>(iut)
            .ignore_interrupts();
    }
    let stuff_error_at = INTEGRATION_BITS + enc_a.len() + GAP_BITS;
    let sof_c = stuff_error_at + 6 + GAP_BITS;
    let sof_d = sof_c + enc_c.len() + INTERMISSION_BITS;
    let retry = sof_d + enc_d.len() + INTERMISSION_BITS;
    bench
        .lt()
        .after_integration()
        .send_frame(&enc_a)
        .release(GAP_BITS)
        .send_bits([DOMINANT; 6])
        .release(GAP_BITS)
        .send_frame(&enc_c)
        .release(INTERMISSION_BITS)
        .send_frame(&enc_d)
        .release(INTERMISSION_BITS + enc_mine.len() + 4)
        .set_bit(
            retry + enc_mine.position(Field::AckSlot, 0).unwrap(),
            Drive::Dominant,
        );
    bench.run_to_bit(sof_c + 5);
    bench.send(&mine, false);
    bench.run(0);
    let end = bench.lt_ref().script_len();
    (bench, end)
}

#[test]
fn servicing_interrupts_does_not_change_what_the_controller_drives() {
    let (mut serviced, end) = traffic(true);
    let (ignored, _) = traffic(false);
    let edges = serviced.iut_edges(0, end);
    assert!(
        edges.len() > 20,
        "ACKs, an error flag and frames: {edges:?}"
    );
    assert_eq!(
        edges,
        ignored.iut_edges(0, end),
        "the same drive with and without the handler's accesses"
    );
    let unserviced = ignored.engine.device::<RegisterIut>(ignored.iut_id());
    assert!(
        unserviced.interrupt_passes().is_empty() && unserviced.node().irq(),
        "the comparison run left its interrupts pending"
    );
    let (_, [a, c, d]) = frames();
    assert_eq!(
        serviced.iut_events(),
        vec![
            NodeEvent::Received(a),
            NodeEvent::BusError(0xA2),
            NodeEvent::Received(c),
            NodeEvent::ArbitrationLost(0),
            NodeEvent::Received(d),
            NodeEvent::TransmitDone(true),
        ],
        "RI, BEI (stuff/RX/ID.28..21), RI, ALI (ID.28), RI, TI with TCS"
    );
}
