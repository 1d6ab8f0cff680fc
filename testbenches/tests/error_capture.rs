//! The error capture block alone (`rtl::bsp::error_capture`): the ECC segment of an error in the
//! arbitration field at every bit count.
//!
//! SJA1000 data sheet, ECC bit interpretation (segment codes `rtl::bsp::ecc_segment`), with the
//! arbitration positions of the ALC coding: an error at position p is in the identifier part whose
//! first position is the largest one not above p (`ARBITRATION_PARTS`); the kernel decodes the
//! positions from the count's bits, so this walks every count the register can hold.

use rtl::bsp::error_capture::{ErrorCapture, ARBITRATION_PARTS};
use rtl::bsp::protocol::ProtocolState;
use rust_hdl::prelude::*;
use sim::engine::rtl_step::clock_cycle;

/// The segment bits of ECC after an error at arbitration count `count`.
fn captured_segment(uut: &mut ErrorCapture, count: u64) -> u64 {
    uut.field.next = ProtocolState::Arbitration;
    uut.count.next = count.into();
    uut.error.next = true;
    clock_cycle(uut, |b| &mut b.clock, "error capture");
    uut.error.next = false;
    assert!(uut.bus_error.val(), "count {count}: no bus error strobe");
    uut.ecc.val().index() as u64 & 0x1F
}

/// The part of position `count`: the last part starting at or before it (the field has 32
/// positions; a count past them keeps the last part).
fn expected_segment(count: u64) -> u64 {
    ARBITRATION_PARTS
        .iter()
        .rev()
        .find(|(start, _)| *start <= count)
        .map(|(_, segment)| *segment)
        .unwrap()
}

#[test]
fn an_error_at_every_arbitration_count_has_the_segment_of_its_identifier_part() {
    let mut uut = ErrorCapture::default();
    uut.connect_all();
    uut.reset.next = true;
    clock_cycle(&mut uut, |b| &mut b.clock, "error capture");
    uut.reset.next = false;
    for count in 0..128 {
        assert_eq!(
            captured_segment(&mut uut, count),
            expected_segment(count),
            "arbitration count {count}"
        );
    }
}
