//! Software model of the SJA1000 acceptance filter, written from the data sheet's bit tables: the
//! reference the RTL `AcceptanceFilter` is tested against.
//!
//! The filter compares the bits of a frame, in bus order (ID.28 first), with acceptance code bits
//! (ACR) laid out from bit 7 of a code register down; a frame bit matches when it equals its ACR bit
//! or when the AMR bit at the same place is 1 (don't care). ID.28 is the first identifier bit on the
//! bus: for a standard frame, ID.28..18 are the 11 bits of its identifier.
//!
//! - BasicCAN: ACR0 = ID.28..21 (for any frame; the controller does not store extended frames in
//!   BasicCAN mode anyway).
//! - Single filter: ACR0 bit 7 onward = the identifier, then RTR (standard: ACR1 bit 4; extended:
//!   ACR3 bit 2); standard frames also compare data byte 1 with ACR2 and data byte 2 with ACR3. The
//!   remaining bits (standard ACR1 bits 3..0, extended ACR3 bits 1..0) are unused.
//! - Dual filter, standard frame: filter 1 = identifier and RTR from ACR0 bit 7, data byte 1 bits 7..4
//!   against ACR1 bits 3..0 and bits 3..0 against ACR3 bits 3..0; filter 2 = identifier and RTR from
//!   ACR2 bit 7. Extended frame: filter 1 = ID.28..13 from ACR0 bit 7, filter 2 = ID.28..13 from ACR2
//!   bit 7. The frame passes if either filter matches.
//!
//! A data byte the frame does not have (remote frame, DLC 0 or 1) matches.

use golden::frame::{Frame, Id};

/// The acceptance filter configuration of the controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct FilterConfig {
    /// PeliCAN mode (CDR.7); `false` = BasicCAN, where only `acr[0]`/`amr[0]` are used.
    pub pelican: bool,
    /// Single filter (MOD.AFM = 1); `false` = dual filter. Ignored in BasicCAN mode.
    pub single_filter: bool,
    /// Acceptance code registers ACR0..ACR3 (BasicCAN: ACR in `acr[0]`).
    pub acr: [u8; 4],
    /// Acceptance mask registers AMR0..AMR3 (BasicCAN: AMR in `amr[0]`); a 1 bit is "don't care".
    pub amr: [u8; 4],
}

impl FilterConfig {
    /// PeliCAN single filter (MOD.AFM = 1).
    pub fn single(acr: [u8; 4], amr: [u8; 4]) -> FilterConfig {
        FilterConfig {
            pelican: true,
            single_filter: true,
            acr,
            amr,
        }
    }

    /// PeliCAN dual filter (MOD.AFM = 0).
    pub fn dual(acr: [u8; 4], amr: [u8; 4]) -> FilterConfig {
        FilterConfig {
            single_filter: false,
            ..FilterConfig::single(acr, amr)
        }
    }
}

/// Whether `frame` passes the acceptance filter configured by `config`.
pub fn accepts(config: &FilterConfig, frame: &Frame) -> bool {
    let id = identifier_bits(frame.id());
    let mut id_rtr = id.clone();
    id_rtr.push(frame.is_remote());
    let data = frame.data_bytes();
    let standard = !frame.id().is_extended();
    if !config.pelican {
        return run_matches(config, 0, &id[..8]);
    }
    if config.single_filter {
        let data_match = !standard
            || data
                .iter()
                .take(2)
                .enumerate()
                .all(|(n, &byte)| run_matches(config, 2 + n, &byte_bits(byte)));
        run_matches(config, 0, &id_rtr) && data_match
    } else if standard {
        let data1_match = data.first().is_none_or(|&byte| {
            let bits = byte_bits(byte);
            (0..4).all(|i| {
                bit_matches(config, 1, 3 - i, bits[i]) && bit_matches(config, 3, 3 - i, bits[4 + i])
            })
        });
        let filter1 = run_matches(config, 0, &id_rtr) && data1_match;
        let filter2 = run_matches(config, 2, &id_rtr);
        filter1 || filter2
    } else {
        run_matches(config, 0, &id[..16]) || run_matches(config, 2, &id[..16])
    }
}

/// The identifier bits in bus order: ID.28 first; 11 bits for a standard, 29 for an extended frame.
fn identifier_bits(id: Id) -> Vec<bool> {
    let (value, len) = match id {
        Id::Standard(id) => (u32::from(id), 11),
        Id::Extended(id) => (id, 29),
    };
    (0..len).rev().map(|n| (value >> n) & 1 == 1).collect()
}

/// The bits of a data byte, bit 7 first.
fn byte_bits(byte: u8) -> [bool; 8] {
    std::array::from_fn(|i| (byte >> (7 - i)) & 1 == 1)
}

/// Frame bit `value` against bit `bit` of ACR`register`/AMR`register`.
fn bit_matches(config: &FilterConfig, register: usize, bit: usize, value: bool) -> bool {
    let dont_care = (config.amr[register] >> bit) & 1 == 1;
    let code = (config.acr[register] >> bit) & 1 == 1;
    dont_care || code == value
}

/// `bits` (first bit first) against the code bits from bit 7 of ACR`first_register` on, continuing
/// with bit 7 of the next register after bit 0.
fn run_matches(config: &FilterConfig, first_register: usize, bits: &[bool]) -> bool {
    bits.iter()
        .enumerate()
        .all(|(p, &value)| bit_matches(config, first_register + p / 8, 7 - p % 8, value))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn standard(id: u16, data: &[u8]) -> Frame {
        Frame::data(Id::standard(id).unwrap(), data).unwrap()
    }

    fn extended(id: u32, data: &[u8]) -> Frame {
        Frame::data(Id::extended(id).unwrap(), data).unwrap()
    }

    use FilterConfig as C;

    fn single(acr: [u8; 4], amr: [u8; 4]) -> FilterConfig {
        C::single(acr, amr)
    }

    fn dual(acr: [u8; 4], amr: [u8; 4]) -> FilterConfig {
        C::dual(acr, amr)
    }

    #[test]
    fn single_standard_id_rtr_and_data() {
        // ID 0x2C5 = 0b0101_1000_101: ACR0 = 0x58, ACR1 = 0b101_0_xxxx (RTR 0).
        let config = single([0x58, 0xA0, 0x12, 0x34], [0x00, 0x0F, 0x00, 0x00]);
        assert!(accepts(&config, &standard(0x2C5, &[0x12, 0x34, 0x56])));
        assert!(!accepts(&config, &standard(0x2C4, &[0x12, 0x34])));
        assert!(!accepts(&config, &standard(0x2C5, &[0x13, 0x34])));
        assert!(!accepts(&config, &standard(0x2C5, &[0x12, 0x35])));
        // Missing data bytes match.
        assert!(accepts(&config, &standard(0x2C5, &[0x12])));
        assert!(accepts(&config, &standard(0x2C5, &[])));
        // RTR is ACR1 bit 4.
        let remote = Frame::remote(Id::standard(0x2C5).unwrap(), 2).unwrap();
        assert!(!accepts(&config, &remote));
        let config = single([0x58, 0xB0, 0x12, 0x34], [0x00, 0x0F, 0x00, 0x00]);
        assert!(accepts(&config, &remote));
    }

    #[test]
    fn single_extended_id_and_rtr_at_acr3_bit2() {
        let id = 0x1234_5678_u32;
        // ID << 3 | RTR << 2 spread over ACR0..ACR3.
        let code = (id << 3).to_be_bytes();
        let config = single(code, [0, 0, 0, 0x03]);
        assert!(accepts(&config, &extended(id, &[0xFF, 0xFF])));
        assert!(!accepts(&config, &extended(id ^ 1, &[])));
        assert!(!accepts(&config, &extended(id ^ (1 << 28), &[])));
        let remote = Frame::remote(Id::extended(id).unwrap(), 0).unwrap();
        assert!(!accepts(&config, &remote));
        let config = single(((id << 3) | 0x04).to_be_bytes(), [0, 0, 0, 0x03]);
        assert!(accepts(&config, &remote));
    }

    #[test]
    fn dual_standard_data_nibbles_and_filter2() {
        // Filter 1: ID 0x2C5, data 1 = 0x9A (ACR1 low nibble 9, ACR3 low nibble A).
        // Filter 2: ID 0x123 = 0b001_0010_0011: ACR2 = 0x24, ACR3 = 0b011_0_1010.
        let config = dual([0x58, 0xA9, 0x24, 0x6A], [0, 0, 0, 0]);
        assert!(accepts(&config, &standard(0x2C5, &[0x9A])));
        assert!(!accepts(&config, &standard(0x2C5, &[0x9B])));
        assert!(!accepts(&config, &standard(0x2C5, &[0x8A])));
        assert!(accepts(&config, &standard(0x2C5, &[])));
        assert!(accepts(&config, &standard(0x123, &[0x00])));
        assert!(!accepts(&config, &standard(0x124, &[0x9A])));
    }

    #[test]
    fn dual_extended_compares_id_28_to_13() {
        let id = 0x1ABC_DEF0_u32;
        let high = ((id >> 13) as u16).to_be_bytes();
        let config = dual([high[0], high[1], 0, 0], [0, 0, 0, 0]);
        assert!(accepts(&config, &extended(id, &[])));
        assert!(accepts(&config, &extended(id ^ 0x1FFF, &[1])));
        assert!(!accepts(&config, &extended(id ^ (1 << 13), &[])));
        let config = dual([0, 0, high[0], high[1]], [0, 0, 0, 0]);
        assert!(accepts(&config, &extended(id, &[])));
    }

    #[test]
    fn basic_can_compares_id_28_to_21_only() {
        let config = FilterConfig {
            pelican: false,
            single_filter: false,
            acr: [0x58, 0x00, 0x00, 0x00],
            amr: [0x00, 0x00, 0x00, 0x00],
        };
        for low in 0..8 {
            assert!(accepts(&config, &standard(0x2C0 | low, &[1, 2])));
        }
        assert!(!accepts(&config, &standard(0x2C5 ^ 0x08, &[])));
    }
}
