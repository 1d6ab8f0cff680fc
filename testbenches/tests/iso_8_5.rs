//! ISO 16845-1:2016 clause 8.5: the IUT as transmitter, error-passive state and bus-off. Each test
//! is named after its clause and runs every elementary test case of it on both IUTs. Bit numbers are
//! lower-tester script bits; script bit 0 is the IUT's SOF.

use sim::bus::Drive;
use sim::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// ISO 11898-1: an error flag is 6 bits, its delimiter 8, the intermission 3 and an error-passive
/// transmitter's suspend transmission 8.
const FLAG: usize = 6;
const DELIMITER: usize = 8;
const INTERMISSION: usize = 3;
const SUSPEND: usize = 8;
/// ISO 11898-1 fault confinement: a transmitter error is +8 on TEC; error passive from 128; bus-off
/// above 255.
const TX_PENALTY: u8 = 8;

fn frame() -> Frame {
    Frame::data(Id::standard(0x001).unwrap(), &[0x80]).unwrap()
}

/// Script position of the first dominant bit of the data field of `frame` (the bit the LT corrupts).
fn dominant_data_bit(frame: &Frame) -> usize {
    let encoded = encode(frame);
    (0..64)
        .map_while(|i| encoded.position(Field::Data, i))
        .find(|&p| encoded.bits[p] == DOMINANT)
        .expect("a dominant data bit")
}

/// 8.5.15: an error-active transmitter becomes error passive within 17 bit times of errors.
///
/// ISO 16845-1 8.5.15: the LT corrupts a data bit of the IUT's frame, then forces the IUT's active
/// error flag recessive for 16 bit times; the IUT shall send a passive error flag and repeat the
/// frame 6 + 8 + 3 + 8 bits after its last dominant bit. By ISO 11898-1 the kind of an error flag is
/// the state of the node detecting the error (an error-active node signals with an active flag, the
/// counter change is the flag's consequence): the data bit error takes TEC to 8, each corrupted flag
/// bit +8 and restarts the flag; the 15th takes TEC from 120 to 128 and is still signalled active, so
/// 16 corrupted flag bits are needed, exactly as the clause drives, and the 16th (TEC 136) is
/// signalled passive. (The same count is what 7.5.7 drives for a receiver: 17 recessive bits.)
fn iso_8_5_15_active_transmitter_becomes_passive_within_17_bit_times(iut: Iut) {
    const CORRUPTED_FLAG_BITS: usize = 16;
    let f = frame();
    let corrupted = dominant_data_bit(&f);
    let flag = corrupted + 1;
    let last_dominant = flag + CORRUPTED_FLAG_BITS - 1;
    let retransmission = last_dominant + 1 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    let encoded = encode(&f);
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench
        .lt()
        .release(retransmission + encoded.len() + 4)
        .set_bit(corrupted, Drive::ForceRecessive)
        .set_bit(
            retransmission + encoded.position(Field::AckSlot, 0).unwrap(),
            Drive::Dominant,
        );
    for bit in flag..flag + CORRUPTED_FLAG_BITS {
        bench.lt().set_bit(bit, Drive::ForceRecessive);
    }
    bench.run_to_bit(retransmission);
    assert_eq!(
        bench.tec(),
        TX_PENALTY * (1 + CORRUPTED_FLAG_BITS as u8),
        "+8 for the data bit error and for each of the 16 flag bit errors"
    );
    assert!(bench.error_passive());
    bench.run(1);
    assert_eq!(
        bench.iut_dominant_bits(flag, retransmission),
        (flag..=last_dominant).collect::<Vec<_>>(),
        "16 active flag bits (each restarted), then a passive flag: recessive"
    );
    let expected: Vec<usize> = (0..encoded.len() - 3)
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .map(|i| retransmission + i)
        .collect();
    assert_eq!(
        bench.iut_dominant_bits(retransmission, retransmission + encoded.len() - 3),
        expected,
        "the frame again, SOF 6 + 8 + 3 + 8 bits after the last dominant flag bit"
    );
    assert_eq!(bench.tec(), 135, "the retransmission succeeds: −1");
}

/// A transmitter cut from the bus (its `rx` reads recessive whatever it sends) until bus-off, bit by
/// bit from ISO 11898-1 (bit error, error flags, fault confinement rules c and d, suspend
/// transmission): SOF bit error (TEC 8); 15 bit errors in its restarted active flags take TEC to 128,
/// the flag after the 15th is still active (decided at an error-active detection, as in 8.5.15) and
/// its bit error gives TEC 136; from then on each attempt is a SOF bit error (+8), a passive flag (6),
/// the delimiter (8), the intermission (3) and suspend transmission (8): 26 bits. The attempt that
/// takes TEC from 248 past 255 is the 16th after TEC 128, so bus-off comes with the SOF bit error of
/// the attempt starting at bit 17 + 25 + 14 × 26 = 406 after the first SOF.
fn iso_8_5_15_cut_transmitter_reaches_bus_off_at_the_standard_bit(iut: Iut) {
    const ATTEMPT: usize = 1 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    const FIRST_PASSIVE_ATTEMPT: usize = 17 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    const BUS_OFF_SOF: usize = FIRST_PASSIVE_ATTEMPT + 14 * ATTEMPT;
    let mut bench = ProtocolBench::iut_transmits(iut, &frame());
    let iut_id = bench.iut_id();
    let now = bench.engine.now();
    bench.engine.disturb_rx(iut_id, now, u64::MAX, RECESSIVE);
    bench.lt().release(BUS_OFF_SOF + 40);
    bench.run_to_bit(17);
    assert_eq!(bench.tec(), 136, "SOF and 16 active flag bits in error");
    assert!(bench.error_passive());
    let mut tec = 136u8;
    for attempt in 0..15 {
        let sof = FIRST_PASSIVE_ATTEMPT + attempt * ATTEMPT;
        bench.run_to_bit(sof + 1);
        if attempt < 14 {
            tec += TX_PENALTY;
            assert_eq!(bench.tec(), tec, "attempt at bit {sof}: SOF bit error +8");
            assert!(!bench.bus_off(), "attempt at bit {sof}");
        }
    }
    assert!(
        bench.bus_off(),
        "bus-off with the SOF bit error at bit {BUS_OFF_SOF}"
    );
    assert_eq!(bench.tec(), 127, "SJA1000: TXERR 127 at bus-off");
    bench.run(0);
    let mut expected: Vec<usize> = (0..17).collect();
    expected.extend((0..15).map(|k| FIRST_PASSIVE_ATTEMPT + k * ATTEMPT));
    assert_eq!(
        bench.iut_dominant_bits(0, BUS_OFF_SOF + 40),
        expected,
        "active flags until the 16th error, then one SOF per 26-bit attempt, then nothing"
    );
}

testbenches::on_both_iuts! {
    iso_8_5_15_active_transmitter_becomes_passive_within_17_bit_times,
    iso_8_5_15_cut_transmitter_reaches_bus_off_at_the_standard_bit,
}
