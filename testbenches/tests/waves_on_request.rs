//! `CANSIM_WAVES`: every bench writes the VCD of its run, named after the test, with its bus timing
//! recorded. Alone in its test binary, since it sets the variable for the whole process.

use golden::frame::{Frame, Id};
use sim::decode::bus_decoder::BusEventKind;
use sim::decode::vcd_reader::{decode_vcd, DecodeOptions};
use sim::engine::bus_timing::BusTiming;
use sim::engine::time::ClockSpec;
use testbenches::controller_bench::{bench_btr, ControllerBench};
use testbenches::protocol_bench::{bt_a, Iut, ProtocolBench};
use testbenches::{CLOCK_HZ, WAVES_ENV};

#[test]
fn benches_write_their_waves_named_after_the_test() {
    let dir = std::env::temp_dir().join(format!("cansim-waves-{}", std::process::id()));
    let frame = Frame::data(Id::Standard(0x1A5), &[0x42]).unwrap();
    std::env::set_var(WAVES_ENV, &dir);
    drop(ProtocolBench::iut_transmits_acknowledged(
        Iut::Core,
        &frame,
        0,
    ));
    ControllerBench::new(1).run_bits(2);
    std::env::remove_var(WAVES_ENV);
    let name = "waves_on_request.benches_write_their_waves_named_after_the_test";
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, [format!("{name}.2.vcd"), format!("{name}.vcd")]);

    let clock = ClockSpec::from_hz(CLOCK_HZ);
    let first = decode_vcd(&dir.join(format!("{name}.vcd")), &DecodeOptions::default()).unwrap();
    assert_eq!(first.file_timing, Some(BusTiming::from_btr(&bt_a(), clock)));
    let kinds: Vec<&BusEventKind> = first.events.iter().map(|e| &e.kind).collect();
    assert_eq!(kinds, [&BusEventKind::Frame { frame, acked: true }]);
    let second = decode_vcd(
        &dir.join(format!("{name}.2.vcd")),
        &DecodeOptions::default(),
    )
    .unwrap();
    assert_eq!(
        second.file_timing,
        Some(BusTiming::from_btr(&bench_btr(), clock))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
