//! Conformance catalog rows that need the SJA1000 register block (docs/CONFORMANCE.md): the
//! complete controller (IUT) against a lower tester that plays golden bit lists, so what the IUT
//! drives on the wire is checked bit by bit, while its registers are read through the host port.
//! Script bits are the lower tester's; "the IUT drove dominant in bit b" is its drive at the
//! nominal sample point of script bit b.

use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT, RECESSIVE};
use rtl::registers::{command, interrupt, mode, pelican, status};
use sim::engine::bus::Drive;
use sim::host::sja1000::{drain_rx, read_rx_message, transmit};
use sim::host::Host;
use testbenches::controller_bench::{
    bench_btr, configure_pelican, ControllerBench, INTEGRATION_BITS,
};

/// The IUT is controller 0 of the bench.
const IUT: usize = 0;
/// Idle bits before the lower tester's first frame: configuration (a few clocks) and integration.
const LEAD_BITS: usize = 20;
/// Idle bits after each frame of the lower tester (intermission and some bus idle).
const GAP_BITS: usize = 10;

fn std_frame(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

fn ext_frame(id: u32, data: &[u8]) -> Frame {
    Frame::data(Id::extended(id).unwrap(), data).unwrap()
}

/// Runs until script bit `bit` of the lower tester starts.
fn run_to_bit(bench: &mut ControllerBench, bit: usize) {
    let at = bench.lt().bit_time(bit).expect("lower tester started");
    assert!(at >= bench.engine.now(), "script bit {bit} is past");
    bench.engine.run_until(at).expect("simulation");
}

/// Runs until the lower tester has played its script (it must have started within a second).
fn run_script(bench: &mut ControllerBench) {
    let limit = bench.engine.now() + sim::engine::time::FS_PER_S;
    let mut finished = false;
    while !finished && bench.engine.now() < limit {
        bench.run_bits(1);
        finished = bench.lt().finished();
    }
    assert!(finished, "the lower tester did not play its script");
}

/// Whether the IUT drove dominant at the nominal sample point of script bit `bit`.
fn iut_dominant_in(bench: &mut ControllerBench, bit: usize) -> bool {
    let sp = bench_btr().sample_point_tq() as u64;
    let lt = bench.lt();
    let at = lt.bit_time(bit).expect("lower tester started") + sp * lt.tq_fs();
    bench.engine.drive_before(bench.id(IUT), at) == Drive::Dominant
}

/// The script bits in `from..to` in which the IUT drove dominant.
fn iut_dominant_bits(bench: &mut ControllerBench, from: usize, to: usize) -> Vec<usize> {
    (from..to).filter(|&b| iut_dominant_in(bench, b)).collect()
}

/// The bus level the lower tester saw at the nominal sample point of script bit `bit`.
fn bus_in(bench: &mut ControllerBench, bit: usize) -> bool {
    let sp = bench_btr().sample_point_tq();
    bench.lt().observed(bit, sp - 1).expect("bit played")
}

/// The dominant bits of `encoded` (the transmitter's own bits: the ACK slot is recessive).
fn dominant_positions(encoded: &EncodedFrame) -> Vec<usize> {
    (0..encoded.len())
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .collect()
}

/// A lower tester that plays `frames` (ACK slot released for the IUT), each followed by
/// [`GAP_BITS`] idle bits, after [`LEAD_BITS`]; returns the bench and each frame's first script bit
/// (and the end of the script as the last entry). The IUT is configured by `setup` (in reset mode,
/// after [`configure_pelican`]) and then writes MOD = `mod_value`.
fn lt_sends(
    frames: &[Frame],
    setup: impl FnOnce(&mut ControllerBench),
    mod_value: u8,
) -> (ControllerBench, Vec<usize>) {
    let mut bench = ControllerBench::with_lower_tester();
    let mut starts = Vec::new();
    bench.lt().release(LEAD_BITS);
    for frame in frames {
        starts.push(bench.lt().script_len());
        bench
            .lt()
            .send_bits(encode(frame).bits.iter().by_vals())
            .release(GAP_BITS);
    }
    starts.push(bench.lt().script_len());
    configure_pelican(&mut bench.host(IUT));
    setup(&mut bench);
    bench.host(IUT).write(pelican::MOD, mod_value);
    (bench, starts)
}

/// Script bits of the ACK slots of `frames` starting at `starts`.
fn ack_slots(frames: &[Frame], starts: &[usize]) -> Vec<usize> {
    frames
        .iter()
        .zip(starts)
        .map(|(f, s)| s + encode(f).position(Field::AckSlot, 0).unwrap())
        .collect()
}

/// FR-08 ACK does not depend on storage: with the FIFO full, or the filter rejecting the ID, the
/// IUT still ACKs a correct frame (FIFO full: DOS, DOI, dropped; filtered: not stored, no RI).
#[test]
fn fr_08_ack_does_not_depend_on_storage() {
    // ---- FIFO full: 4 × 13 + 11 = 63 bytes stored; the 6th and 7th frames do not fit.
    let mut frames: Vec<Frame> = (0..4u8)
        .map(|i| ext_frame(0x1234_5670 + i as u32, &[0x11 * i; 8]))
        .collect();
    frames.push(std_frame(0x3E5, &[0xA5; 8]));
    frames.push(Frame::remote(Id::standard(0x001).unwrap(), 0).unwrap());
    frames.push(std_frame(0x7F0, &[0x0F]));
    let (mut bench, starts) = lt_sends(&frames, |_| {}, 0);
    let after = |k: usize| starts[k + 1] - GAP_BITS + 5;

    run_to_bit(&mut bench, after(4));
    assert_eq!(bench.host(IUT).read(pelican::RMC), 5);
    assert_eq!(bench.host(IUT).read(pelican::SR) & status::DOS, 0);
    assert_eq!(bench.host(IUT).read(pelican::IR), interrupt::RI);

    run_to_bit(&mut bench, after(5));
    assert_eq!(bench.host(IUT).read(pelican::RMC), 5, "6th frame dropped");
    assert_eq!(bench.host(IUT).read(pelican::SR) & status::DOS, status::DOS);
    assert_eq!(
        bench.host(IUT).read(pelican::IR),
        interrupt::RI | interrupt::DOI
    );

    run_script(&mut bench);
    assert_eq!(bench.host(IUT).read(pelican::RMC), 5, "7th frame dropped");
    assert_eq!(bench.host(IUT).read(pelican::SR) & status::DOS, status::DOS);
    assert_eq!(
        bench.host(IUT).read(pelican::IR),
        interrupt::RI,
        "no second DOI before CDO"
    );
    let end = *starts.last().unwrap();
    let acks = ack_slots(&frames, &starts);
    assert_eq!(
        iut_dominant_bits(&mut bench, 0, end),
        acks,
        "the IUT drives exactly the ACK slots (the dropped frames' too), nothing else"
    );
    for &ack in &acks {
        assert_eq!(bus_in(&mut bench, ack), DOMINANT, "bus in ACK slot {ack}");
    }
    assert_eq!(bench.host(IUT).read(pelican::RXERR), 0);
    assert_eq!(bench.host(IUT).read(pelican::TXERR), 0);
    assert_eq!(drain_rx(&mut bench.host(IUT)), frames[..5].to_vec());

    // ---- Filter rejecting: single filter, ID.28..21 must be 0xAA (standard IDs 0x550..0x557).
    let frames = [
        std_frame(0x123, &[1, 2]),
        ext_frame(0x00AB_CDEF, &[3]),
        std_frame(0x555, &[4, 5, 6]),
    ];
    let (mut bench, starts) = lt_sends(
        &frames,
        |bench| {
            let mut host = bench.host(IUT);
            host.write(pelican::ACR0, 0xAA);
            host.write(pelican::AMR0, 0x00);
        },
        mode::AFM,
    );
    let after = |k: usize| starts[k + 1] - GAP_BITS + 5;
    assert_eq!(bench.host(IUT).read(pelican::MOD), mode::AFM);
    for k in 0..2 {
        run_to_bit(&mut bench, after(k));
        assert_eq!(bench.host(IUT).read(pelican::RMC), 0, "frame {k} rejected");
        assert_eq!(bench.host(IUT).read(pelican::SR) & status::RBS, 0);
        assert_eq!(bench.host(IUT).read(pelican::IR), 0, "no RI for frame {k}");
        assert!(!bench.node(IUT).irq(), "irq_n high");
    }
    run_script(&mut bench);
    assert_eq!(bench.host(IUT).read(pelican::IR), interrupt::RI);
    let end = *starts.last().unwrap();
    assert_eq!(
        iut_dominant_bits(&mut bench, 0, end),
        ack_slots(&frames, &starts),
        "rejected frames are acknowledged like the accepted one"
    );
    assert_eq!(drain_rx(&mut bench.host(IUT)), vec![frames[2]]);
    assert_eq!(bench.host(IUT).read(pelican::RXERR), 0);
}

/// The IUT, configured by `setup` (in reset mode, after [`configure_pelican`]), then with MOD =
/// `mod_value` and integrated, transmits `frame` with CMR = `cmd`; the lower tester starts at its
/// SOF and plays the frame's length plus 20 idle bits, driving the ACK slot dominant if `ack`.
/// Returns the bench after the script and the script length.
fn iut_transmits(
    frame: &Frame,
    cmd: u8,
    setup: impl FnOnce(&mut Host),
    mod_value: u8,
    ack: bool,
) -> (ControllerBench, usize) {
    let encoded = encode(frame);
    let mut bench = ControllerBench::with_lower_tester();
    let end = encoded.len() + 20;
    bench.lt().start_on_dominant().release(end);
    if ack {
        let slot = encoded.position(Field::AckSlot, 0).unwrap();
        bench.lt().set_bit(slot, Drive::Dominant);
    }
    configure_pelican(&mut bench.host(IUT));
    setup(&mut bench.host(IUT));
    bench.host(IUT).write(pelican::MOD, mod_value);
    bench.run_bits(INTEGRATION_BITS);
    transmit(&mut bench.host(IUT), frame, cmd);
    run_script(&mut bench);
    (bench, end)
}

/// RT-05 (self reception): with SRR the IUT sends its frame as usual and also stores it.
#[test]
fn rt_05_self_reception_stores_the_own_frame() {
    let frame = ext_frame(0x0C0F_FEE5, &[0xCA, 0xFE, 0xBA, 0xBE]);
    let encoded = encode(&frame);
    let (mut bench, end) = iut_transmits(&frame, command::SRR, |_| {}, 0, true);
    assert_eq!(
        iut_dominant_bits(&mut bench, 0, end),
        dominant_positions(&encoded),
        "the frame on the wire equals the golden bit list, sent once"
    );
    let sr = bench.host(IUT).read(pelican::SR);
    assert_eq!(sr & (status::TBS | status::TCS), status::TBS | status::TCS);
    assert_eq!(sr & status::RBS, status::RBS);
    assert_eq!(
        bench.host(IUT).read(pelican::IR),
        interrupt::TI | interrupt::RI
    );
    assert_eq!(bench.host(IUT).read(pelican::RMC), 1);
    assert_eq!(read_rx_message(&mut bench.host(IUT)), frame);
    assert_eq!(bench.host(IUT).read(pelican::TXERR), 0);

    // The acceptance filter applies to the own frame: rejected, it is sent but not stored.
    let reject_all = |host: &mut Host| {
        host.write(pelican::ACR0, 0x00);
        host.write(pelican::AMR0, 0x00);
    };
    let (mut bench, end) = iut_transmits(&frame, command::SRR, reject_all, mode::AFM, true);
    assert_eq!(
        iut_dominant_bits(&mut bench, 0, end),
        dominant_positions(&encoded)
    );
    assert_eq!(bench.host(IUT).read(pelican::SR) & status::TCS, status::TCS);
    assert_eq!(bench.host(IUT).read(pelican::IR), interrupt::TI, "no RI");
    assert_eq!(bench.host(IUT).read(pelican::RMC), 0);
}

/// RT-05 (self test): in self-test mode a transmission without any ACK succeeds.
#[test]
fn rt_05_self_test_succeeds_without_ack() {
    let frame = std_frame(0x2B7, &[0x01, 0x80, 0xFF]);
    let encoded = encode(&frame);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let (mut bench, end) = iut_transmits(&frame, command::TR, |_| {}, mode::STM, false);
    assert_eq!(
        iut_dominant_bits(&mut bench, 0, end),
        dominant_positions(&encoded),
        "the golden bit list once: no error flag, no retransmission"
    );
    assert_eq!(bus_in(&mut bench, ack), RECESSIVE, "nobody acknowledged");
    let sr = bench.host(IUT).read(pelican::SR);
    assert_eq!(sr & (status::TBS | status::TCS), status::TBS | status::TCS);
    assert_eq!(bench.host(IUT).read(pelican::IR), interrupt::TI);
    assert_eq!(
        bench.host(IUT).read(pelican::TXERR),
        0,
        "no ACK error counted"
    );
    assert_eq!(bench.host(IUT).read(pelican::RMC), 0, "TR: not stored");

    // With SRR the own frame is stored as well.
    let (mut bench, end) = iut_transmits(&frame, command::SRR, |_| {}, mode::STM, false);
    assert_eq!(
        iut_dominant_bits(&mut bench, 0, end),
        dominant_positions(&encoded)
    );
    assert_eq!(
        bench.host(IUT).read(pelican::IR),
        interrupt::TI | interrupt::RI
    );
    assert_eq!(drain_rx(&mut bench.host(IUT)), vec![frame]);
    assert_eq!(bench.host(IUT).read(pelican::TXERR), 0);

    // Without STM the same lone transmission fails with an ACK error (the control case).
    let (mut bench, _) = iut_transmits(&frame, command::TR, |_| {}, 0, false);
    assert_eq!(
        bench.host(IUT).read(pelican::SR) & status::TBS,
        0,
        "retrying"
    );
    assert!(bench.host(IUT).read(pelican::TXERR) >= 8);
    bench.host(IUT).write(pelican::MOD, mode::RM);
}
