//! The reference workload of the simulation speed figures: complete controllers at 16 MHz on one
//! bus at 500 kbit/s (BTR0 0x40, BTR1 0x1C), reached only through their registers. Node A sends
//! 8-byte standard data frames back to back (it writes each into its TX buffer, requests it and
//! waits for TI); every other node takes each frame from its RX buffer when RI interrupts and
//! releases the buffer. The clocks differ by 300 ppm from node to node, so no two edges coincide.

use std::path::PathBuf;
use std::time::Instant;

use rtl::registers::{clock_divider, command, interrupt, mode, pelican, status};

use crate::controller_node::{ControllerNode, ModelEngine};
use crate::engine::{Device, DeviceId, Engine};
use crate::frame::{Frame, Id};
use crate::frame_buffer::{buffer_len, decode_buffer, encode_buffer, FRAME_BUFFER_BYTES};
use crate::host::Host;
use crate::time::{ClockSpec, FS_PER_MS};

/// Controller clock of the workload.
const CLOCK_HZ: f64 = 16e6;
/// Clock offset of each further node from the one before.
const PPM_STEP: f64 = 300.0;
/// Bit timing: BRP 0 with the 16 MHz clock, 16 tq per bit: 500 kbit/s.
const BTR0: u8 = 0x40;
/// TSEG1 13 tq, TSEG2 2 tq: sample point at 87.5 %.
const BTR1: u8 = 0x1C;
/// Data bytes of every frame.
const DATA_BYTES: usize = 8;
/// Longest wait for an interrupt or for the bus to be idle (a frame takes about 0.25 ms).
const IRQ_TIMEOUT_FS: u64 = FS_PER_MS;

/// Speed of one run of [`reference_workload`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchResult {
    /// Clock edges of all nodes, halved (one node pair steps two edges per clock period), per
    /// second of wall-clock time.
    pub pair_cycles_per_s: f64,
    /// The same per second of processor time of the running thread: the figure that does not
    /// depend on what else the machine runs.
    pub pair_cycles_per_cpu_s: f64,
    /// Frames sent per second of wall-clock time.
    pub frames_per_s: f64,
    /// Wall-clock time of the measured part (configuration excluded).
    pub seconds: f64,
}

/// Runs the reference workload with `nodes` controllers (at least 2) stepped by `engine`, sending
/// `frames` frames, with a VCD of every node written (to a temporary file, removed afterwards)
/// when `trace` is set. Checks that every receiver got every frame intact.
pub fn reference_workload(
    engine: ModelEngine,
    nodes: usize,
    trace: bool,
    frames: usize,
) -> Result<BenchResult, String> {
    if nodes < 2 {
        return Err(format!("the workload needs 2 nodes or more, not {nodes}"));
    }
    let mut bus = Engine::new();
    let mut ids = Vec::with_capacity(nodes);
    for n in 0..nodes {
        let clock = ClockSpec::with_ppm(CLOCK_HZ, PPM_STEP * n as f64);
        let node = ControllerNode::with_engine(&format!("n{n}"), clock, engine)
            .map_err(|e| e.to_string())?;
        ids.push(bus.add(node, 0));
    }
    for &id in &ids {
        configure(&mut Host::new(&mut bus, id));
    }
    for &id in &ids {
        wait_for_bus_idle(&mut Host::new(&mut bus, id))?;
    }
    let vcd = trace.then(|| {
        std::env::temp_dir().join(format!(
            "cansim-bench-{}-{}.vcd",
            engine.name(),
            std::process::id()
        ))
    });
    if let Some(path) = &vcd {
        bus.trace_vcd(path)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    let edges_before = bus.edges();
    let cpu_start = thread_cpu_seconds();
    let start = Instant::now();
    let result = send_frames(&mut bus, &ids, frames);
    let finished = bus.finish_trace();
    let seconds = start.elapsed().as_secs_f64();
    let cpu_seconds = thread_cpu_seconds() - cpu_start;
    remove(vcd);
    result?;
    finished.map_err(|e| format!("cannot finish the VCD: {e}"))?;
    let pair_cycles = (bus.edges() - edges_before) as f64 / 2.0;
    Ok(BenchResult {
        pair_cycles_per_s: pair_cycles / seconds,
        pair_cycles_per_cpu_s: pair_cycles / cpu_seconds,
        frames_per_s: frames as f64 / seconds,
        seconds,
    })
}

/// Median, minimum and maximum of a few measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// The middle value (the upper one of the middle two for an even count).
    pub median: f64,
    /// The smallest value.
    pub min: f64,
    /// The largest value.
    pub max: f64,
}

impl Spread {
    /// The spread of `values`; `None` if there are none.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Spread> {
        let mut sorted: Vec<f64> = values.into_iter().collect();
        sorted.sort_by(f64::total_cmp);
        Some(Spread {
            median: *sorted.get(sorted.len() / 2)?,
            min: sorted[0],
            max: sorted[sorted.len() - 1],
        })
    }
}

impl std::fmt::Display for Spread {
    /// `median (min …, max …)`, with the formatter's precision (none by default).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = f.precision().unwrap_or(0);
        write!(
            f,
            "{:.p$} (min {:.p$}, max {:.p$})",
            self.median, self.min, self.max
        )
    }
}

fn remove(path: Option<PathBuf>) {
    if let Some(path) = path {
        let _ = std::fs::remove_file(path);
    }
}

/// PeliCAN operation at 500 kbit/s, every frame accepted, RI and TI enabled.
fn configure(host: &mut Host) {
    host.write(pelican::CDR, clock_divider::PELICAN);
    host.write(pelican::BTR0, BTR0);
    host.write(pelican::BTR1, BTR1);
    for k in 0..4 {
        host.write(pelican::AMR0 + k, 0xFF);
    }
    host.write(pelican::IER, interrupt::RI | interrupt::TI);
    host.write(pelican::MOD, 0);
    assert_eq!(host.read(pelican::MOD) & mode::RM, 0, "operating mode");
}

/// Polls the status register until the node has seen the bus idle (neither receiving nor
/// transmitting: integration done), so that it takes part in the first frame.
fn wait_for_bus_idle(host: &mut Host) -> Result<(), String> {
    let limit = host.engine().now() + IRQ_TIMEOUT_FS;
    while host.read(pelican::SR) & (status::RS | status::TS) != 0 {
        if host.engine().now() > limit {
            return Err(format!("{}: never saw the bus idle", host.node().name()));
        }
    }
    Ok(())
}

/// The frame number `k` of the workload.
fn frame(k: usize) -> Frame {
    let id = Id::standard((k % 0x800) as u16).expect("11-bit identifier");
    Frame::data(id, &[k as u8; DATA_BYTES]).expect("8 data bytes")
}

/// Node `ids[0]` sends `frames` frames; the others receive each one.
fn send_frames(bus: &mut Engine, ids: &[DeviceId], frames: usize) -> Result<(), String> {
    let (sender, receivers) = ids.split_first().expect("two nodes or more");
    for k in 0..frames {
        let expected = frame(k);
        let buffer = encode_buffer(&expected);
        let mut host = Host::new(bus, *sender);
        for (i, byte) in buffer.iter().take(buffer_len(buffer[0])).enumerate() {
            host.write(pelican::FRAME + i as u8, *byte);
        }
        host.write(pelican::CMR, command::TR);
        let mut pending = receivers.len();
        let mut sent = false;
        while !sent || pending > 0 {
            let limit = bus.now() + IRQ_TIMEOUT_FS;
            let irq = bus
                .run_while(limit, |e| {
                    ids.iter().any(|&id| e.device::<ControllerNode>(id).irq())
                })
                .map_err(|e| format!("simulation: {e}"))?;
            if !irq {
                return Err(format!("frame {k}: no interrupt within 1 ms"));
            }
            for &id in receivers {
                if bus.device::<ControllerNode>(id).irq() {
                    let received = take_frame(&mut Host::new(bus, id));
                    if let Some(frame) = received {
                        if frame != expected {
                            return Err(format!("frame {k} received as {frame:?}"));
                        }
                        pending -= 1;
                    }
                }
            }
            if bus.device::<ControllerNode>(*sender).irq() {
                sent |= Host::new(bus, *sender).read(pelican::IR) & interrupt::TI != 0;
            }
        }
    }
    Ok(())
}

/// Services a receiver's interrupt: the frame in its RX buffer, released, if RI was pending.
fn take_frame(host: &mut Host) -> Option<Frame> {
    if host.read(pelican::IR) & interrupt::RI == 0 {
        return None;
    }
    let mut bytes = [0u8; FRAME_BUFFER_BYTES];
    bytes[0] = host.read(pelican::FRAME);
    let len = buffer_len(bytes[0]);
    for (i, byte) in bytes.iter_mut().enumerate().take(len).skip(1) {
        *byte = host.read(pelican::FRAME + i as u8);
    }
    host.write(pelican::CMR, command::RRB);
    Some(decode_buffer(&bytes))
}

/// Processor time of the calling thread, in seconds.
fn thread_cpu_seconds() -> f64 {
    #[repr(C)]
    struct Timespec {
        tv_sec: i64,
        tv_nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, time: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut time = Timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `time` is a valid out-parameter of the layout of 64-bit Linux's `struct timespec`.
    let status = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut time) };
    assert_eq!(status, 0, "clock_gettime of the thread's CPU clock");
    time.tv_sec as f64 + time.tv_nsec as f64 * 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_engines_run_the_workload_and_deliver_every_frame() {
        for engine in ModelEngine::ALL {
            let result =
                reference_workload(engine, 3, false, 2).unwrap_or_else(|e| panic!("{engine}: {e}"));
            assert!(result.pair_cycles_per_s > 0.0, "{engine}: {result:?}");
            assert!(result.frames_per_s > 0.0, "{engine}: {result:?}");
        }
    }

    #[test]
    fn the_spread_names_median_min_and_max() {
        let s = Spread::of([3.0, 1.0, 5.0, 2.0, 4.0]).unwrap();
        assert_eq!((s.median, s.min, s.max), (3.0, 1.0, 5.0));
        assert_eq!(s.to_string(), "3 (min 1, max 5)");
        assert_eq!(format!("{s:.1}"), "3.0 (min 1.0, max 5.0)");
        assert_eq!(Spread::of([]), None);
    }

    #[test]
    fn one_node_is_refused() {
        let err = reference_workload(ModelEngine::RustHdl, 1, false, 1).unwrap_err();
        assert!(err.contains("2 nodes or more"), "{err}");
    }
}
