//! SJA1000 register behaviour of the complete controller, observed only through its host port.

use rtl::registers::{command, interrupt, pelican, status};
use sim::frame::{Frame, Id};
use testbenches::controller_bench::{drain_rx, transmit, ControllerBench};

fn std_frame(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

#[test]
fn a_frame_sent_through_registers_is_stored_by_the_other_controller() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x123, &[1, 2, 3, 4]);
    transmit(&mut bench.host(0), &frame, command::TR);
    assert!(bench.run_until_irq(1, 200), "receiver raises RI");
    let ir = bench.host(1).read(pelican::IR);
    assert_eq!(ir & interrupt::RI, interrupt::RI);
    assert_eq!(bench.host(1).read(pelican::RMC), 1);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);
    assert!(bench.run_until_irq(0, 50), "transmitter raises TI");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    let sr = bench.host(0).read(pelican::SR);
    assert_eq!(sr & (status::TBS | status::TCS), status::TBS | status::TCS);
}
