//! The bit timing logic passes rust-hdl's connectivity checks and generates Verilog with its ports.
use rtl::bit_timing::BitTiming;
use rust_hdl::prelude::*;

#[test]
fn bit_timing_generates_checked_verilog() {
    let mut uut = BitTiming::default();
    uut.connect_all();
    check_all(&uut).expect("rust-hdl connectivity checks");
    let verilog = generate_verilog(&uut);
    for port in [
        "input wire  clock;",
        "input wire  rx;",
        "output reg  sample_point;",
        "output reg  transmit_point;",
    ] {
        assert!(
            verilog.contains(port),
            "missing `{port}` in the generated Verilog"
        );
    }
}

#[test]
fn can_core_generates_checked_verilog() {
    let mut uut = rtl::can_core::CanCore::default();
    uut.connect_all();
    check_all(&uut).expect("rust-hdl connectivity checks");
    let verilog = generate_verilog(&uut);
    assert!(verilog.contains("output reg  tx;"));
    if let Ok(dir) = std::env::var("CANSIM_VERILOG_DIR") {
        std::fs::write(std::path::Path::new(&dir).join("can_core.v"), verilog).unwrap();
    }
}

#[test]
fn can_controller_generates_checked_verilog() {
    let mut uut = rtl::can_controller::CanController::default();
    uut.connect_all();
    check_all(&uut).expect("rust-hdl connectivity checks");
    let verilog = generate_verilog(&uut);
    for port in [
        "input wire  clock;",
        "input wire  reset;",
        "input wire  [7:0] addr;",
        "input wire  [7:0] wdata;",
        "input wire  we;",
        "input wire  re;",
        "output reg  [7:0] rdata;",
        "input wire  rx;",
        "output reg  tx;",
        "output reg  irq_n;",
        "output reg  clkout;",
    ] {
        assert!(
            verilog.contains(port),
            "missing `{port}` in the generated Verilog"
        );
    }
    if let Ok(dir) = std::env::var("CANSIM_VERILOG_DIR") {
        std::fs::write(std::path::Path::new(&dir).join("can_controller.v"), verilog).unwrap();
    }
}
