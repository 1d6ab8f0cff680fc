//! The bit timing logic generates Verilog that passes rust-hdl's own checks.
use rtl::bit_timing::BitTiming;
use rust_hdl::prelude::*;

#[test]
fn bit_timing_generates_checked_verilog() {
    let mut uut = BitTiming::default();
    uut.connect_all();
    check_all(&uut).expect("rust-hdl connectivity checks");
    let verilog = generate_verilog(&uut);
    assert!(verilog.contains("module top"));
    std::fs::create_dir_all("../target/verilog").unwrap();
    std::fs::write("../target/verilog/bit_timing.v", verilog).unwrap();
}
