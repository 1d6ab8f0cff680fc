//! Conformance BT scenarios that need the protocol engine (BT-12 …): synchronisation of a transmitter
//! around the ACK and at the start of a frame. Bit numbers are lower-tester script bits.

use sim::bus::Drive;
use sim::can_node::NodeEvent;
use sim::frame::{encode, Field, Frame, Id};
use testbenches::protocol_bench::ProtocolBench;

#[test]
fn bt_12_negative_resync_at_the_crc_delimiter_before_the_ack() {
    let frame = Frame::data(Id::standard(0x456).unwrap(), &[0xC3, 0x3C]).unwrap();
    let encoded = encode(&frame);
    let delimiter = encoded.position(Field::CrcDelim, 0).unwrap();
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    // The acknowledging node's ACK edge comes early: the CRC delimiter is shortened by 1 .. TSEG2 tq.
    for early_tq in 1..=4 {
        let mut bench = ProtocolBench::iut_transmits(&frame);
        bench
            .lt()
            .release(encoded.len() + 4)
            .set_bit(ack, Drive::Dominant)
            .lengthen_bit(delimiter, -early_tq);
        bench.run(1);
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::TransmitDone(true)],
            "ACK {early_tq} tq early is read correctly"
        );
        assert_eq!(bench.iut().tec(), 0);
    }
}
