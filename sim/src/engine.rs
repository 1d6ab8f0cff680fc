//! The simulation engine: single-threaded direct stepping of several devices, each on its own clock,
//! on one wired-AND [`Bus`].
//!
//! The engine is a time-ordered event loop: it always takes the earliest pending rising clock edge of any
//! device (ties go to the device added first), gives the device the bus level it sees just before that
//! edge, and applies the drive the device returns from that edge on. With equal clocks this is lockstep;
//! with ppm offsets every device keeps its own time. The engine is the one place that knows about time:
//! testbenches talk in frames, bits and quanta through the devices and the lower tester.

use std::any::Any;
use std::io;
use std::path::{Path, PathBuf};

use crate::bus::{Bus, Drive};
use crate::bus_decoder::BusTiming;
use crate::time::ClockSpec;
use crate::trace::{Probe, VcdTracer};

/// A participant on the bus, stepped on the rising edges of its own clock.
pub trait Device: Any {
    /// Scope name in traces and reports.
    fn name(&self) -> &str;
    /// The device's clock.
    fn clock(&self) -> ClockSpec;
    /// One rising clock edge at `t_fs`; `rx` is the bus level the device sees just before the edge.
    /// Returns what the device drives from this edge on.
    fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive;
    /// Signals to trace besides `tx` and `rx`.
    fn probes(&self) -> Vec<Probe> {
        Vec::new()
    }
    /// Current values of [`Device::probes`], in the same order.
    fn probe_values(&self, _values: &mut [u64]) {}
    /// `self` as `Any`, for [`Engine::device`].
    fn as_any(&self) -> &dyn Any;
    /// `self` as mutable `Any`, for [`Engine::device_mut`].
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

/// Index of a device in an [`Engine`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DeviceId(pub usize);

struct Slot {
    device: Box<dyn Device>,
    clock: ClockSpec,
    edges: u64,
    next_edge: u64,
    line: usize,
    drive: Drive,
    rx: bool,
    disturbances: Vec<Disturbance>,
    probe_values: Vec<u64>,
}

/// A time window in which one device sees a fixed level instead of the bus (a local fault: a
/// transceiver or wiring disturbance only that node sees).
#[derive(Clone, Copy, Debug)]
struct Disturbance {
    from_fs: u64,
    to_fs: u64,
    /// The level seen, or `None`: the bus level inverted.
    level: Option<bool>,
}

struct Tracing {
    tracer: VcdTracer,
    /// The devices with a scope in the trace: those added before it started.
    devices: usize,
    /// Times at which the bus level may change (a drive changed and reaches the bus then).
    pending: std::collections::BinaryHeap<std::cmp::Reverse<u64>>,
}

/// The event loop stepping every device on its own clock.
///
/// An engine that is still tracing when it is dropped finishes its VCD then (errors are printed), so
/// a test that panics still leaves the waves of its run.
pub struct Engine {
    slots: Vec<Slot>,
    bus: Bus,
    now: u64,
    edges: u64,
    tracing: Option<Tracing>,
    /// A trace to start at the first step, once every device is added.
    deferred_trace: Option<(PathBuf, BusTiming)>,
}

impl Default for Engine {
    fn default() -> Self {
        Engine::new()
    }
}

impl Engine {
    /// An engine with no devices, at time 0.
    pub fn new() -> Engine {
        Engine {
            slots: Vec::new(),
            bus: Bus::new(),
            now: 0,
            edges: 0,
            tracing: None,
            deferred_trace: None,
        }
    }

    /// Adds a device connected to the bus through `delay_fs` of propagation delay (each way). A
    /// device added after tracing started has no scope of its own in the VCD (the bus it drives is
    /// still traced).
    pub fn add<D: Device>(&mut self, device: D, delay_fs: u64) -> DeviceId {
        let clock = device.clock();
        let probes = device.probes().len();
        let line = self.bus.add_line(delay_fs);
        self.slots.push(Slot {
            device: Box::new(device),
            clock,
            edges: 0,
            next_edge: clock.edge(0),
            line,
            drive: Drive::Recessive,
            rx: true,
            disturbances: Vec::new(),
            probe_values: vec![0; probes],
        });
        DeviceId(self.slots.len() - 1)
    }

    /// Makes device `id` see `level` instead of the bus at its clock edges in `from_fs..to_fs` (the
    /// other devices and the bus are unaffected).
    pub fn disturb_rx(&mut self, id: DeviceId, from_fs: u64, to_fs: u64, level: bool) {
        self.slots[id.0].disturbances.push(Disturbance {
            from_fs,
            to_fs,
            level: Some(level),
        });
    }

    /// Makes device `id` see the inverted bus level at its clock edges in `from_fs..to_fs`.
    pub fn invert_rx(&mut self, id: DeviceId, from_fs: u64, to_fs: u64) {
        self.slots[id.0].disturbances.push(Disturbance {
            from_fs,
            to_fs,
            level: None,
        });
    }

    /// Starts writing a VCD of the bus and every device to `path`; call after adding the devices. A
    /// trace already running is finished first.
    pub fn trace_vcd(&mut self, path: &Path) -> io::Result<()> {
        self.start_trace(path, None)
    }

    /// As [`Engine::trace_vcd`], recording the bus's bit timing in the VCD header for decoders.
    pub fn trace_vcd_timed(&mut self, path: &Path, timing: BusTiming) -> io::Result<()> {
        self.start_trace(path, Some(&timing))
    }

    /// Traces as [`Engine::trace_vcd_timed`] from the first step on, so devices can still be added
    /// until then (an error creating the file is returned by that step).
    pub fn trace_vcd_from_first_step(&mut self, path: &Path, timing: BusTiming) {
        self.deferred_trace = Some((path.to_path_buf(), timing));
    }

    /// Starts tracing now; an explicit trace replaces a deferred one and ends a running one (whose
    /// file is finished).
    fn start_trace(&mut self, path: &Path, timing: Option<&BusTiming>) -> io::Result<()> {
        self.deferred_trace = None;
        self.finish_trace()?;
        let devices: Vec<(String, Vec<Probe>)> = self
            .slots
            .iter()
            .map(|s| (s.device.name().to_string(), s.device.probes()))
            .collect();
        self.tracing = Some(Tracing {
            tracer: VcdTracer::create(path, &devices, timing)?,
            devices: devices.len(),
            pending: Default::default(),
        });
        Ok(())
    }

    /// Ends tracing: writes the rest of the VCD and moves it into place. Returns the path, if tracing.
    pub fn finish_trace(&mut self) -> io::Result<Option<std::path::PathBuf>> {
        self.flush_bus_trace(u64::MAX)?;
        match self.tracing.take() {
            Some(t) => t.tracer.finish(self.now).map(Some),
            None => Ok(None),
        }
    }

    /// Keep the whole drive history of every line for [`Engine::drive_before`] and
    /// [`Engine::bus_level_before`] queries about the past.
    pub fn keep_history(&mut self) {
        self.bus.keep_history(true);
    }

    /// Time of the last processed clock edge.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// Number of clock edges processed, all devices together.
    pub fn edges(&self) -> u64 {
        self.edges
    }

    /// The bus level just before `t` (needs [`Engine::keep_history`] for times well in the past).
    pub fn bus_level_before(&self, t: u64) -> bool {
        self.bus.level_before(t)
    }

    /// What `id` drove just before `t` (needs [`Engine::keep_history`] for times well in the past).
    pub fn drive_before(&self, id: DeviceId, t: u64) -> Drive {
        self.bus.drive_before(self.slots[id.0].line, t)
    }

    /// The device `id`, as its concrete type.
    ///
    /// Panics if `T` is not the type that was added under `id`.
    pub fn device<T: Device>(&self, id: DeviceId) -> &T {
        self.slots[id.0]
            .device
            .as_any()
            .downcast_ref()
            .expect("device type does not match its id")
    }

    /// The device `id`, as its concrete type, mutably.
    pub fn device_mut<T: Device>(&mut self, id: DeviceId) -> &mut T {
        self.slots[id.0]
            .device
            .as_any_mut()
            .downcast_mut()
            .expect("device type does not match its id")
    }

    /// Time of the next clock edge the engine will process.
    pub fn next_edge(&self) -> Option<u64> {
        self.slots.iter().map(|s| s.next_edge).min()
    }

    /// Processes the earliest pending clock edge.
    pub fn step(&mut self) -> io::Result<()> {
        if let Some((path, timing)) = self.deferred_trace.take() {
            self.start_trace(&path, Some(&timing))?;
        }
        let Some(i) = self.earliest() else {
            return Ok(());
        };
        let t = self.slots[i].next_edge;
        self.flush_bus_trace(t)?;
        self.now = t;
        self.edges += 1;
        let line = self.slots[i].line;
        let slot = &mut self.slots[i];
        let bus = self.bus.level_seen_by(line, t);
        let rx = match slot
            .disturbances
            .iter()
            .find(|d| (d.from_fs..d.to_fs).contains(&t))
        {
            Some(d) => d.level.unwrap_or(!bus),
            None => bus,
        };
        let drive = slot.device.rising_edge(t, rx);
        slot.rx = rx;
        slot.edges += 1;
        slot.next_edge = slot.clock.edge(slot.edges);
        if drive != slot.drive {
            slot.drive = drive;
            self.bus.set_drive(line, t, drive);
            if let Some(tracing) = &mut self.tracing {
                tracing
                    .pending
                    .push(std::cmp::Reverse(t + self.bus.delay_fs(line)));
            }
        }
        if let Some(tracing) = self.tracing.as_mut().filter(|t| i < t.devices) {
            let slot = &mut self.slots[i];
            slot.device.probe_values(&mut slot.probe_values);
            let tx = slot.drive.level();
            tracing
                .tracer
                .device(i, t, tx, slot.rx, &slot.probe_values)?;
        }
        if self.edges.is_multiple_of(4096) {
            self.bus.prune(t);
        }
        Ok(())
    }

    /// Processes every clock edge before `t_fs`.
    pub fn run_until(&mut self, t_fs: u64) -> io::Result<()> {
        while self.next_edge().is_some_and(|t| t < t_fs) {
            self.step()?;
        }
        Ok(())
    }

    /// Steps until `done(self)` holds (checked after every edge) or `limit_fs` is reached. Returns
    /// whether `done` held.
    pub fn run_while<F: FnMut(&Engine) -> bool>(
        &mut self,
        limit_fs: u64,
        mut done: F,
    ) -> io::Result<bool> {
        while self.next_edge().is_some_and(|t| t < limit_fs) {
            self.step()?;
            if done(self) {
                return Ok(true);
            }
        }
        Ok(false)
    }

    fn earliest(&self) -> Option<usize> {
        let mut best: Option<(u64, usize)> = None;
        for (i, s) in self.slots.iter().enumerate() {
            if best.is_none_or(|(t, _)| s.next_edge < t) {
                best = Some((s.next_edge, i));
            }
        }
        best.map(|(_, i)| i)
    }

    /// Writes the bus-level changes that happen before `t` (changes at `t` itself wait, so that every
    /// device stepping at `t` has applied its drive first).
    fn flush_bus_trace(&mut self, t: u64) -> io::Result<()> {
        let Some(tracing) = &mut self.tracing else {
            return Ok(());
        };
        while let Some(&std::cmp::Reverse(at)) = tracing.pending.peek() {
            if at >= t {
                break;
            }
            tracing.pending.pop();
            let level = self.bus.level_before(at + 1);
            tracing.tracer.bus(at, level)?;
        }
        Ok(())
    }
}

impl Drop for Engine {
    fn drop(&mut self) {
        if self.tracing.is_some() {
            if let Err(e) = self.finish_trace() {
                eprintln!("cannot finish the VCD trace: {e}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Drives a fixed level and records what it sees at each edge.
    struct Probe {
        drive: Drive,
        seen: Vec<bool>,
    }

    impl Device for Probe {
        fn name(&self) -> &str {
            "probe"
        }
        fn clock(&self) -> ClockSpec {
            ClockSpec::from_hz(1e6)
        }
        fn rising_edge(&mut self, _t_fs: u64, rx: bool) -> Drive {
            self.seen.push(rx);
            self.drive
        }
        fn as_any(&self) -> &dyn Any {
            self
        }
        fn as_any_mut(&mut self) -> &mut dyn Any {
            self
        }
    }

    fn probe(drive: Drive) -> Probe {
        Probe {
            drive,
            seen: Vec::new(),
        }
    }

    #[test]
    fn a_disturbance_changes_what_one_device_sees_only_in_its_window() {
        let mut engine = Engine::new();
        let driver = engine.add(probe(Drive::Dominant), 0);
        let victim = engine.add(probe(Drive::Recessive), 0);
        let us = ClockSpec::from_hz(1e6).period_fs();
        engine.disturb_rx(victim, 3 * us, 5 * us, true);
        engine.invert_rx(victim, 7 * us, 8 * us);
        engine.run_until(10 * us).unwrap();
        let seen = |id| engine.device::<Probe>(id).seen.clone();
        // Edge 0 sees the idle bus; from edge 1 on the driver's dominant level.
        let expected: Vec<bool> = (0..10)
            .map(|k| k == 0 || (3..5).contains(&k) || k == 7)
            .collect();
        assert_eq!(seen(victim), expected);
        assert_eq!(seen(driver), (0..10).map(|k| k == 0).collect::<Vec<_>>());
    }

    #[test]
    fn a_trace_from_the_first_step_records_the_timing_and_is_finished_when_replaced_or_dropped() {
        let path = std::env::temp_dir().join(format!("cansim-engine-{}.vcd", std::process::id()));
        let us = ClockSpec::from_hz(1e6).period_fs();
        let timing = BusTiming::new(4 * us, 0.75).unwrap();
        {
            let mut engine = Engine::new();
            engine.add(probe(Drive::Recessive), 0);
            engine.trace_vcd_from_first_step(&path, timing);
            engine.add(probe(Drive::Dominant), 0);
            engine.run_until(3 * us).unwrap();
            engine.add(probe(Drive::Recessive), 0);
            engine.run_until(6 * us).unwrap();
            assert!(!path.exists(), "written only when finished");
            let second = path.with_extension("2.vcd");
            engine.trace_vcd(&second).unwrap();
            assert!(path.exists(), "a new trace finishes the running one");
            drop(engine);
            assert!(second.exists());
            std::fs::remove_file(&second).unwrap();
        }
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert!(
            text.contains(&crate::vcd_reader::timing_comment(&timing)),
            "{text}"
        );
        assert_eq!(
            text.matches("$scope module probe $end").count(),
            2,
            "the devices added before the first step: {text}"
        );
        assert!(
            text.ends_with("#5000\n"),
            "traced up to the last edge: {text}"
        );
    }
}
