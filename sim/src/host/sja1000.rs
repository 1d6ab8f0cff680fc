//! The host side of an SJA1000 in PeliCAN mode, written once: set-up in reset mode, loading the
//! transmit buffer, reading and releasing received messages. Generic over [`RegisterPort`], so the
//! host model, the Linux driver model, the benches' hosts and the speed workload share the same
//! register sequences (SJA1000 data sheet: configuration registers are written in reset mode; in
//! operating mode the frame window at 16..28 is the TX buffer for writes and the head message of
//! the RX FIFO for reads; CMR.RRB releases that message).
//!
//! Register *values* are named as values: [`BTR0_500K_AT_16MHZ`] is what a host writes to BTR0,
//! `pelican::BTR0` is where.

use golden::frame::Frame;
use rtl::registers::{clock_divider, command, mode, pelican, status};

use super::frame_buffer::{buffer_len, decode_buffer, encode_buffer, FRAME_BUFFER_BYTES};
use super::RegisterPort;

/// BTR0 for 500 kbit/s at 16 MHz: BRP 0 (tq = 2 clocks), SJW 1 tq.
pub const BTR0_500K_AT_16MHZ: u8 = 0x00;
/// BTR0 for 500 kbit/s at 16 MHz with SJW 2 tq (BRP 0).
pub const BTR0_500K_SJW2_AT_16MHZ: u8 = 0x40;
/// BTR1 for 500 kbit/s at 16 MHz: TSEG1 13 tq, TSEG2 2 tq (16 tq per bit, sample point 87.5 %),
/// one sample.
pub const BTR1_500K_AT_16MHZ: u8 = 0x1C;
/// BTR0 for 250 kbit/s at 16 MHz with SJW 2 tq: BRP 1 (tq = 4 clocks); with
/// [`BTR1_500K_AT_16MHZ`]'s 16 tq per bit.
pub const BTR0_250K_SJW2_AT_16MHZ: u8 = 0x41;
/// BTR0 for 125 kbit/s at 16 MHz with SJW 2 tq: BRP 3 (tq = 8 clocks); with
/// [`BTR1_500K_AT_16MHZ`]'s 16 tq per bit.
pub const BTR0_125K_SJW2_AT_16MHZ: u8 = 0x43;
/// BTR0 for 1 Mbit/s at 16 MHz: BRP 0 (tq = 2 clocks), SJW 1 tq.
pub const BTR0_1M_AT_16MHZ: u8 = 0x00;
/// BTR0 for 1 Mbit/s at 16 MHz with SJW 2 tq (BRP 0).
pub const BTR0_1M_SJW2_AT_16MHZ: u8 = 0x40;
/// BTR1 for 1 Mbit/s at 16 MHz: TSEG1 5 tq, TSEG2 2 tq (8 tq per bit, sample point 75 %), one
/// sample.
pub const BTR1_1M_AT_16MHZ: u8 = 0x14;
/// ACR value of an open filter (with [`AMR_OPEN`]).
pub const ACR_OPEN: u8 = 0x00;
/// AMR value of an open filter: every bit "don't care".
pub const AMR_OPEN: u8 = 0xFF;

/// What [`set_up_pelican`] writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PelicanSetup {
    /// BTR0 value.
    pub btr0: u8,
    /// BTR1 value.
    pub btr1: u8,
    /// ACR0..ACR3 values.
    pub acr: [u8; 4],
    /// AMR0..AMR3 values.
    pub amr: [u8; 4],
    /// IER value.
    pub ier: u8,
}

impl PelicanSetup {
    /// The bit timing `btr0`/`btr1`, an open filter and every interrupt enabled.
    pub fn open(btr0: u8, btr1: u8) -> PelicanSetup {
        PelicanSetup {
            btr0,
            btr1,
            acr: [ACR_OPEN; 4],
            amr: [AMR_OPEN; 4],
            ier: 0xFF,
        }
    }

    /// The same set-up with interrupt enables `ier`.
    pub fn with_ier(self, ier: u8) -> PelicanSetup {
        PelicanSetup { ier, ..self }
    }
}

/// Enters reset mode and configures PeliCAN mode: CDR.7, BTR0, BTR1, ACR/AMR pairs, IER. The
/// controller stays in reset mode ([`enter_operating_mode`] leaves it).
pub fn set_up_pelican(port: &mut impl RegisterPort, setup: &PelicanSetup) {
    port.write(pelican::MOD, mode::RM);
    port.write(pelican::CDR, clock_divider::PELICAN);
    port.write(pelican::BTR0, setup.btr0);
    port.write(pelican::BTR1, setup.btr1);
    for (k, (&acr, &amr)) in setup.acr.iter().zip(&setup.amr).enumerate() {
        port.write(pelican::ACR0 + k as u8, acr);
        port.write(pelican::AMR0 + k as u8, amr);
    }
    port.write(pelican::IER, setup.ier);
}

/// Writes MOD with `mode_bits` (RM clear: operating mode) and returns MOD as read back.
pub fn enter_operating_mode(port: &mut impl RegisterPort, mode_bits: u8) -> u8 {
    port.write(pelican::MOD, mode_bits & !mode::RM);
    port.read(pelican::MOD)
}

/// Writes `frame` into the transmit buffer (frame information, identifier and data bytes: the
/// bytes its DLC and format use).
pub fn load_tx_buffer(port: &mut impl RegisterPort, frame: &Frame) {
    let buffer = encode_buffer(frame);
    for (k, byte) in buffer.iter().take(buffer_len(buffer[0])).enumerate() {
        port.write(pelican::FRAME + k as u8, *byte);
    }
}

/// Loads `frame` and writes `cmd` (TR, SRR, with AT for a single shot) to CMR.
pub fn transmit(port: &mut impl RegisterPort, frame: &Frame, cmd: u8) {
    load_tx_buffer(port, frame);
    port.write(pelican::CMR, cmd);
}

/// Reads the head message of the RX FIFO through the frame window: the frame information, then
/// the identifier and data bytes it announces (without releasing it).
pub fn read_rx_message(port: &mut impl RegisterPort) -> Frame {
    let mut bytes = [0u8; FRAME_BUFFER_BYTES];
    bytes[0] = port.read(pelican::FRAME);
    let len = buffer_len(bytes[0]);
    for (k, byte) in bytes.iter_mut().enumerate().take(len).skip(1) {
        *byte = port.read(pelican::FRAME + k as u8);
    }
    decode_buffer(&bytes)
}

/// Releases the head message (CMR.RRB).
pub fn release_rx(port: &mut impl RegisterPort) {
    port.write(pelican::CMR, command::RRB);
}

/// Reads and releases every stored message, head first, while SR.RBS says one is there.
pub fn drain_rx(port: &mut impl RegisterPort) -> Vec<Frame> {
    let mut frames = Vec::new();
    while port.read(pelican::SR) & status::RBS != 0 {
        frames.push(read_rx_message(port));
        release_rx(port);
    }
    frames
}

#[cfg(test)]
mod tests {
    use super::*;
    use golden::btr::Btr;
    use golden::frame::Id;

    /// Records the accesses; reads answer from a script.
    #[derive(Default)]
    struct Recorder {
        writes: Vec<(u8, u8)>,
        reads: Vec<u8>,
        answers: Vec<u8>,
    }

    impl RegisterPort for Recorder {
        fn write(&mut self, addr: u8, value: u8) {
            self.writes.push((addr, value));
        }
        fn read(&mut self, addr: u8) -> u8 {
            self.reads.push(addr);
            self.answers.remove(0)
        }
    }

    #[test]
    fn named_bit_timings_are_what_their_names_say() {
        let clock = 16_000_000.0;
        let rate = |b0, b1| clock / f64::from(Btr::from_registers(b0, b1).clocks_per_bit());
        assert_eq!(rate(BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ), 500_000.0);
        assert_eq!(rate(BTR0_500K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ), 500_000.0);
        assert_eq!(rate(BTR0_1M_AT_16MHZ, BTR1_1M_AT_16MHZ), 1_000_000.0);
        assert_eq!(rate(BTR0_1M_SJW2_AT_16MHZ, BTR1_1M_AT_16MHZ), 1_000_000.0);
        assert_eq!(rate(BTR0_250K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ), 250_000.0);
        assert_eq!(rate(BTR0_125K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ), 125_000.0);
        for btr0 in [
            BTR0_500K_SJW2_AT_16MHZ,
            BTR0_1M_SJW2_AT_16MHZ,
            BTR0_250K_SJW2_AT_16MHZ,
            BTR0_125K_SJW2_AT_16MHZ,
        ] {
            let sjw_field = Btr::from_registers(btr0, BTR1_500K_AT_16MHZ).sjw;
            assert_eq!(sjw_field + 1, 2, "BTR0 {btr0:#04x}: SJW 2 tq");
        }
    }

    #[test]
    fn set_up_writes_the_data_sheet_order_in_reset_mode() {
        let mut port = Recorder::default();
        set_up_pelican(&mut port, &PelicanSetup::open(0x01, 0x2F).with_ier(0x03));
        assert_eq!(port.writes[0], (pelican::MOD, mode::RM));
        assert_eq!(port.writes[1], (pelican::CDR, clock_divider::PELICAN));
        assert_eq!(
            &port.writes[2..4],
            &[(pelican::BTR0, 0x01), (pelican::BTR1, 0x2F)]
        );
        assert_eq!(port.writes[4], (pelican::ACR0, ACR_OPEN));
        assert_eq!(port.writes[11], (pelican::AMR3, AMR_OPEN));
        assert_eq!(port.writes.last(), Some(&(pelican::IER, 0x03)));
    }

    #[test]
    fn a_message_is_loaded_and_read_back_through_the_frame_window() {
        let frame = Frame::data(Id::extended(0x1234_5678).unwrap(), &[1, 2, 3]).unwrap();
        let mut port = Recorder::default();
        transmit(&mut port, &frame, command::TR);
        // Frame information, 4 identifier bytes, 3 data bytes, then CMR.
        assert_eq!(port.writes.len(), 1 + 4 + 3 + 1);
        assert_eq!(port.writes.last(), Some(&(pelican::CMR, command::TR)));
        let loaded: Vec<u8> = port.writes[..8].iter().map(|&(_, v)| v).collect();
        let mut reader = Recorder {
            answers: loaded,
            ..Recorder::default()
        };
        assert_eq!(read_rx_message(&mut reader), frame);
        assert_eq!(reader.reads, (16..24).collect::<Vec<u8>>());
    }
}
