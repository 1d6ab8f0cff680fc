//! The lower tester and the bus: scripts play at quantum resolution, every modification lands where it
//! is asked, forcing overrides other drivers, and the record tells what each device put on the bus.

use golden::btr::Btr;
use golden::frame::{DOMINANT as D, RECESSIVE as R};
use sim::engine::bus::Drive;
use sim::engine::time::{ClockSpec, FS_PER_NS};
use sim::engine::Engine;
use sim::nodes::lower_tester::LowerTester;
use testbenches::{bench_engine, CLOCK_HZ};

fn btr() -> Btr {
    Btr::from_quanta(1, 5, 2, 1, false).unwrap() // 8 tq of 4 clocks
}

fn run_to_end(engine: &mut Engine, lt: sim::engine::DeviceId) {
    engine
        .run_while(sim::engine::time::FS_PER_S, |e| {
            e.device::<LowerTester>(lt).finished()
        })
        .unwrap();
}

/// The bus level the lower tester saw in each quantum of script bit `bit`.
fn quanta_of_bit(lt: &LowerTester, bit: usize) -> Vec<bool> {
    let (from, to) = (lt.bit_start_quantum(bit), lt.bit_start_quantum(bit + 1));
    lt.observed_quanta()[from..to].to_vec()
}

#[test]
fn flipped_forced_and_resized_bits_appear_on_the_bus_where_asked() {
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    let mut engine = bench_engine(&btr(), clock);
    let mut lt = LowerTester::new("lt", clock, btr());
    lt.send_bits([R, D, R, D, R, R])
        .flip_bit(2)
        .lengthen_bit(3, 3)
        .lengthen_bit(4, -5)
        .force(5, 2, 3, Drive::Dominant);
    let lt = engine.add(lt, 0);
    run_to_end(&mut engine, lt);
    let lt = engine.device::<LowerTester>(lt);
    assert_eq!(lt.bit_start_quantum(4), 4 * 8 + 3);
    assert_eq!(lt.bit_start_quantum(5), 4 * 8 + 3 + 3);
    assert_eq!(quanta_of_bit(lt, 0), vec![R; 8]);
    assert_eq!(quanta_of_bit(lt, 2), vec![D; 8], "flipped");
    assert_eq!(quanta_of_bit(lt, 3), vec![D; 11], "lengthened by 3 tq");
    assert_eq!(quanta_of_bit(lt, 4), vec![R; 3], "shortened by 5 tq");
    assert_eq!(
        quanta_of_bit(lt, 5),
        vec![R, R, D, D, D, R, R, R],
        "forced quanta 2..5"
    );
    let tq = lt.tq_fs();
    assert_eq!(tq, 4 * clock.period_fs());
    assert_eq!(lt.bit_time(1).unwrap() - lt.bit_time(0).unwrap(), 8 * tq);
}

#[test]
fn forcing_recessive_overrides_a_dominant_node_and_the_record_tells_both() {
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    let mut engine = bench_engine(&btr(), clock);
    engine.keep_history();
    let mut tester = LowerTester::new("lt", clock, btr());
    tester.release(4).force(1, 0, 8, Drive::ForceRecessive);
    let mut node = LowerTester::new("node", clock, btr());
    node.send_bits([D, D, D, D]);
    let tester = engine.add(tester, 0);
    let node = engine.add(node, 0);
    run_to_end(&mut engine, tester);
    let lt = engine.device::<LowerTester>(tester);
    assert_eq!(quanta_of_bit(lt, 0), vec![D; 8], "the node's dominant bit");
    assert_eq!(quanta_of_bit(lt, 1), vec![R; 8], "forced recessive over it");
    assert_eq!(quanta_of_bit(lt, 2), vec![D; 8]);
    let middle_of_bit_1 = lt.quantum_time(12).unwrap();
    assert_eq!(engine.drive_before(node, middle_of_bit_1), Drive::Dominant);
    assert_eq!(
        engine.drive_before(tester, middle_of_bit_1),
        Drive::ForceRecessive
    );
    assert_eq!(engine.bus_level_before(middle_of_bit_1), R);
}

#[test]
fn start_on_dominant_aligns_quantum_zero_with_the_edge_and_delays_shift_what_each_sees() {
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    let mut engine = bench_engine(&btr(), clock);
    engine.keep_history();
    let mut node = LowerTester::new("node", clock, btr());
    node.release(3).send_bits([D, R, D]);
    let mut tester = LowerTester::new("lt", clock, btr());
    tester.start_on_dominant().release(3);
    let node = engine.add(node, 0);
    let delay = 250 * FS_PER_NS; // exactly one quantum (4 clocks at 16 MHz)
    let tester = engine.add(tester, delay);
    run_to_end(&mut engine, tester);
    let edge = engine.device::<LowerTester>(node).bit_time(3).unwrap();
    let lt = engine.device::<LowerTester>(tester);
    assert_eq!(
        lt.started_at(),
        Some(edge + delay),
        "the tester sees the edge one delay late and starts there"
    );
    assert_eq!(quanta_of_bit(lt, 0), vec![D; 8]);
    assert_eq!(quanta_of_bit(lt, 1), vec![R; 8]);
    assert_eq!(quanta_of_bit(lt, 2), vec![D; 8]);
}

#[test]
fn clocks_with_ppm_offsets_keep_their_own_time() {
    let btr = btr();
    let mut engine = bench_engine(&btr, ClockSpec::from_hz(CLOCK_HZ));
    let fast = ClockSpec::with_ppm(CLOCK_HZ, 10_000.0);
    let slow = ClockSpec::with_ppm(CLOCK_HZ, -10_000.0);
    let mut a = LowerTester::new("fast", fast, btr);
    a.release(100);
    let mut b = LowerTester::new("slow", slow, btr);
    b.release(100);
    let a = engine.add(a, 0);
    let b = engine.add(b, 0);
    run_to_end(&mut engine, b);
    let (ta, tb) = (
        engine.device::<LowerTester>(a).tq_fs(),
        engine.device::<LowerTester>(b).tq_fs(),
    );
    let ratio = tb as f64 / ta as f64;
    assert!((ratio - 1.01 / 0.99).abs() < 1e-6, "ratio {ratio}");
    assert!(
        engine.device::<LowerTester>(a).finished(),
        "the fast one finished first"
    );
}
