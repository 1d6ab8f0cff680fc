//! CRC-15/CAN, the frame check sequence of classic CAN (Bosch CAN 2.0 A/B, ISO 11898-1).
//!
//! The generator polynomial is `x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1`; the
//! register starts at zero, bits are shifted in most significant bit first, there is no
//! reflection and no final XOR. On a CAN bus the CRC is computed over the *unstuffed*
//! bits from the start of frame bit up to the last data bit (or the DLC of a remote frame).
//!
//! [`Crc15`] is the incremental, bit-serial form (one [`Crc15::push`] per bit, as the
//! hardware does it); [`crc15`] is the one-shot convenience wrapper.

/// The CRC-15/CAN generator polynomial without its implicit `x^15` term:
/// `x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1`.
pub const CRC15_POLY: u16 = 0x4599;

/// Mask of the 15 register bits.
const MASK: u16 = 0x7FFF;

/// Incremental bit-serial CRC-15/CAN register.
///
/// ```
/// use golden::crc15::{crc15, Crc15};
/// let mut crc = Crc15::new();
/// for bit in [false, true, true, false] {
///     crc.push(bit);
/// }
/// assert_eq!(crc.value(), crc15([false, true, true, false]));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Crc15 {
    reg: u16,
}

impl Crc15 {
    /// A register holding the initial value 0.
    pub const fn new() -> Self {
        Crc15 { reg: 0 }
    }

    /// Shifts one message bit (`true` = 1 = recessive) into the register.
    pub fn push(&mut self, bit: bool) {
        let feedback = bit ^ (self.reg & 0x4000 != 0);
        self.reg = (self.reg << 1) & MASK;
        if feedback {
            self.reg ^= CRC15_POLY;
        }
    }

    /// The current 15-bit CRC value (bit 14 is the first CRC bit sent on the wire).
    pub const fn value(&self) -> u16 {
        self.reg
    }
}

/// The CRC-15/CAN of a bit sequence given MSB (first transmitted bit) first.
pub fn crc15(bits: impl IntoIterator<Item = bool>) -> u16 {
    let mut crc = Crc15::new();
    bits.into_iter().for_each(|bit| crc.push(bit));
    crc.value()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Full generator including the `x^15` term, as a list of 16 coefficients, highest first.
    const GENERATOR: [u8; 16] = [1, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1];

    /// Independent reference: textbook polynomial long division of `M(x) * x^15` by the
    /// generator over GF(2), on a vector of 0/1 coefficients (no shift register).
    fn reference_crc(bits: &[bool]) -> u16 {
        let mut dividend: Vec<u8> = bits.iter().map(|&b| u8::from(b)).collect();
        dividend.extend([0; 15]);
        for start in 0..bits.len() {
            if dividend[start] == 1 {
                for (k, g) in GENERATOR.iter().enumerate() {
                    dividend[start + k] ^= g;
                }
            }
        }
        dividend[bits.len()..]
            .iter()
            .fold(0u16, |acc, &c| (acc << 1) | u16::from(c))
    }

    fn bits_of_bytes(bytes: &[u8]) -> Vec<bool> {
        bytes
            .iter()
            .flat_map(|byte| (0..8).rev().map(move |i| byte >> i & 1 == 1))
            .collect()
    }

    fn bits_of_value(value: u16, width: u32) -> Vec<bool> {
        (0..width).rev().map(|i| value >> i & 1 == 1).collect()
    }

    #[test]
    fn polynomial_constant_matches_generator() {
        let from_generator = GENERATOR[1..]
            .iter()
            .fold(0u16, |acc, &c| (acc << 1) | u16::from(c));
        assert_eq!(CRC15_POLY, from_generator);
    }

    #[test]
    fn empty_and_zero_messages_have_zero_crc() {
        assert_eq!(crc15([]), 0);
        assert_eq!(crc15([false; 40]), 0);
    }

    #[test]
    fn single_one_bit_gives_the_polynomial() {
        // 1 * x^15 mod G = G - x^15 = the polynomial constant.
        assert_eq!(crc15([true]), CRC15_POLY);
        assert_eq!(reference_crc(&[true]), CRC15_POLY);
    }

    #[test]
    fn catalogue_check_value() {
        // The customary check value of CRC-15/CAN: the ASCII string "123456789".
        let bits = bits_of_bytes(b"123456789");
        assert_eq!(reference_crc(&bits), 0x059E);
        assert_eq!(crc15(bits), 0x059E);
    }

    #[test]
    fn known_vectors_against_reference() {
        let vectors: [&[u8]; 4] = [&[0x00], &[0xFF], &[0xDE, 0xAD, 0xBE, 0xEF], &[0x80, 0x01]];
        for bytes in vectors {
            let bits = bits_of_bytes(bytes);
            assert_eq!(crc15(bits.clone()), reference_crc(&bits), "{bytes:02X?}");
        }
    }

    #[test]
    fn message_followed_by_its_crc_has_zero_residue() {
        let mut bits = bits_of_bytes(b"CAN frame");
        let crc = crc15(bits.clone());
        bits.extend(bits_of_value(crc, 15));
        assert_eq!(crc15(bits), 0);
    }

    proptest! {
        #[test]
        fn matches_reference(bits in proptest::collection::vec(any::<bool>(), 0..200)) {
            prop_assert_eq!(crc15(bits.clone()), reference_crc(&bits));
        }

        #[test]
        fn residue_is_zero(bits in proptest::collection::vec(any::<bool>(), 0..200)) {
            let mut message = bits.clone();
            message.extend(bits_of_value(crc15(bits), 15));
            prop_assert_eq!(crc15(message), 0);
        }

        #[test]
        fn value_fits_in_15_bits(bits in proptest::collection::vec(any::<bool>(), 0..200)) {
            prop_assert!(crc15(bits) <= MASK);
        }
    }
}
