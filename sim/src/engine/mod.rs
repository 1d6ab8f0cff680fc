//! The simulation engine: single-threaded direct stepping of several devices, each on its own clock,
//! on one wired-AND [`Bus`].
//!
//! The engine is a time-ordered event loop: it always takes the earliest pending rising clock edge of any
//! device (ties go to the device added first), gives the device the bus level it sees just before that
//! edge, and applies the drive the device returns from that edge on. With equal clocks this is lockstep;
//! with ppm offsets every device keeps its own time. The engine is the one place that knows about time:
//! testbenches talk in frames, bits and quanta through the devices and the lower tester.

pub mod bus;
pub mod bus_timing;
pub mod rng;
pub mod rtl_step;
pub mod time;
pub mod trace;

use std::any::Any;
use std::io;
use std::path::{Path, PathBuf};

use crate::engine::bus::{Bus, BusFault, Drive};
use crate::engine::bus_timing::BusTiming;
use crate::engine::time::ClockSpec;
use crate::engine::trace::{Probe, VcdTracer};
use golden::frame::RECESSIVE;

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
    /// The values of [`Device::probe_values`] packed into one word, each probe's bits above the
    /// previous probe's (the first at bit 0), for a device that has them at hand so; the probes
    /// must fit in 62 bits. The tracer then does not call [`Device::probe_values`] (on a traced
    /// edge that call and the packing cost as much as writing the changes). `None` (the
    /// default): the tracer calls it.
    fn packed_probe_values(&self) -> Option<u64> {
        None
    }
    /// How many of the device's next rising edges change nothing outside it, provided it sees
    /// `rx` at each of them: neither what it drives nor (when `traced`) a probe, nor anything a
    /// caller can read from it between edges except free-running counters (edge skipping,
    /// [`Engine::set_edge_skipping`]). 0, the default: the device does not skip.
    fn quiet_edges(&self, _rx: bool, _traced: bool) -> u64 {
        0
    }
    /// Runs `edges` of its quiet edges at once, seeing `rx` at each (at most
    /// [`Device::quiet_edges`] gave for the same `rx` and `traced`). `checked`: also step a copy
    /// edge by edge and panic if the two differ.
    fn skip_edges(&mut self, _edges: u64, _rx: bool, _traced: bool, _checked: bool) {
        unreachable!("a device without quiet edges is never skipped")
    }
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
    /// What the device drives (its `tx` pin).
    pin: Drive,
    /// What reaches the bus: the pin, or a [`DriveOverride`].
    drive: Drive,
    rx: bool,
    disturbances: Vec<Disturbance>,
    overrides: Vec<DriveOverride>,
    probe_values: Vec<u64>,
    /// The device has left the bus ([`Engine::leave`]): never stepped, its place free for another.
    departed: bool,
    /// The time of its first edge that is not quiet ([`Device::quiet_edges`]), while known: forgotten
    /// when it is stepped, changed from outside, or the bus level may have changed.
    quiet_until: Option<u64>,
    /// Quiet edges from its next one on that it jumps over in one step when the last of them comes
    /// first in time order (0: none), found while the engine runs ([`Engine::park_quiet_edges`]):
    /// cut back when the bus changes before them, jumped over or dropped before a run returns.
    parked: u64,
}

impl Slot {
    /// The time of the slot's turn: its next edge, or the last of its parked edges.
    fn turn(&self) -> u64 {
        match self.parked {
            0 => self.next_edge,
            parked => self.clock.edge(self.edges + parked - 1),
        }
    }

    /// What reaches the bus from this device at its edge at `t` when its pin drives `pin`.
    fn effective_drive(&self, t: u64, pin: Drive) -> Drive {
        self.overrides
            .iter()
            .find(|o| (o.from_fs..o.to_fs).contains(&t))
            .map_or(pin, |o| o.drive)
    }
}

/// A time window in which what one device drives is replaced (a disconnected or stuck
/// transmitter); the device's own pin is unaffected.
#[derive(Clone, Copy, Debug)]
struct DriveOverride {
    from_fs: u64,
    to_fs: u64,
    drive: Drive,
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

/// Whether the engine jumps over clock edges at which provably nothing changes outside the device
/// (issue 21: the bit timing only counting between its sample and transmit points). Chosen by
/// `CAN_SKIP_EDGES` (`off`, `on`, `checked`) or [`Engine::set_edge_skipping`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EdgeSkipping {
    /// Every edge of every device is stepped (the default).
    #[default]
    Off,
    /// Quiet edges are skipped: the same results, fewer steps.
    On,
    /// As `On`, and every skip is checked against stepping a copy of the device edge by edge
    /// (slow; for tests).
    Checked,
}

/// The environment variable that chooses [`EdgeSkipping`] for new engines.
pub const SKIP_ENV: &str = "CAN_SKIP_EDGES";

impl EdgeSkipping {
    /// The mode `CAN_SKIP_EDGES` chooses: unset or empty is [`EdgeSkipping::Off`]; anything but `off`,
    /// `on` or `checked` is an error naming them.
    pub fn from_env() -> Result<EdgeSkipping, String> {
        let parsed = match std::env::var(SKIP_ENV) {
            Ok(value) => value.parse(),
            Err(std::env::VarError::NotPresent) => Ok(EdgeSkipping::Off),
            Err(std::env::VarError::NotUnicode(value)) => value.to_string_lossy().parse(),
        };
        parsed.map_err(|e| format!("{SKIP_ENV}={e}"))
    }

    /// The name `CAN_SKIP_EDGES` takes.
    pub fn name(self) -> &'static str {
        match self {
            EdgeSkipping::Off => "off",
            EdgeSkipping::On => "on",
            EdgeSkipping::Checked => "checked",
        }
    }
}

impl std::str::FromStr for EdgeSkipping {
    type Err = String;

    fn from_str(value: &str) -> Result<EdgeSkipping, String> {
        match value {
            "" | "off" => Ok(EdgeSkipping::Off),
            "on" => Ok(EdgeSkipping::On),
            "checked" => Ok(EdgeSkipping::Checked),
            other => Err(format!(
                "`{other}` is not an edge skipping mode: use `off` (the default), `on` or \
                 `checked`"
            )),
        }
    }
}

/// The bus prunes its history every this many edges.
const PRUNE_EDGES: u64 = 4096;

/// How many of the slot's edges from its next one on come before `t`.
fn edges_before(slot: &Slot, t: u64) -> u64 {
    if slot.departed {
        return 0;
    }
    let period = slot.clock.period_fs();
    // Edge n comes before t when phase + n * period < t: n < ceil((t - phase) / period).
    let before = t.saturating_sub(slot.clock.edge(0)).div_ceil(period);
    before.saturating_sub(slot.edges)
}

/// Derives a traced value from the bus level changes (time, new level): the new value when it
/// changes.
pub type BusAnnotator = Box<dyn FnMut(u64, bool) -> Option<u64>>;

/// Who wants to know the bus level changes, and the times at which the level may change next.
struct BusObservers {
    tracer: Option<VcdTracer>,
    /// A signal traced beside `bus`, derived from its changes.
    annotation: Option<(Probe, BusAnnotator)>,
    /// The devices with a scope in the trace: those added before it started.
    traced_devices: usize,
    /// Changes recorded for [`Engine::take_bus_changes`], if watching.
    changes: Option<Vec<(u64, bool)>>,
    /// The last level reported.
    last: bool,
    /// Times at which the bus level may change (a drive changed and reaches the bus then, or a
    /// bus fault begins or ends).
    pending: std::collections::BinaryHeap<std::cmp::Reverse<u64>>,
}

impl Default for BusObservers {
    fn default() -> Self {
        BusObservers {
            tracer: None,
            traced_devices: 0,
            annotation: None,
            changes: None,
            last: RECESSIVE,
            pending: Default::default(),
        }
    }
}

impl BusObservers {
    fn active(&self) -> bool {
        self.tracer.is_some() || self.changes.is_some()
    }

    fn expect_change_at(&mut self, t: u64) {
        if self.active() {
            self.pending.push(std::cmp::Reverse(t));
        }
    }
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
    /// The device of the last edge stepped.
    last_stepped: Option<DeviceId>,
    observers: BusObservers,
    /// A trace to start at the first step, once every device is added.
    deferred_trace: Option<(PathBuf, BusTiming)>,
    skipping: EdgeSkipping,
    /// Edges skipped rather than stepped (counted in `edges` too).
    skipped: u64,
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
            last_stepped: None,
            observers: BusObservers::default(),
            deferred_trace: None,
            skipping: EdgeSkipping::from_env().unwrap_or_else(|e| panic!("{e}")),
            skipped: 0,
        }
    }

    /// Chooses whether quiet edges are skipped (the default is `CAN_SKIP_EDGES`'s choice).
    pub fn set_edge_skipping(&mut self, skipping: EdgeSkipping) {
        self.skipping = skipping;
        self.forget_quiet();
    }

    /// Whether quiet edges are skipped.
    pub fn edge_skipping(&self) -> EdgeSkipping {
        self.skipping
    }

    /// How many of [`Engine::edges`] were skipped rather than stepped.
    pub fn skipped_edges(&self) -> u64 {
        self.skipped
    }

    /// Forgets every device's quiet edges (the bus, a fault or the tracing changed).
    fn forget_quiet(&mut self) {
        for slot in &mut self.slots {
            slot.quiet_until = None;
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
            pin: Drive::Recessive,
            drive: Drive::Recessive,
            rx: true,
            disturbances: Vec::new(),
            overrides: Vec::new(),
            probe_values: vec![0; probes],
            departed: false,
            quiet_until: None,
            parked: 0,
        });
        self.forget_quiet();
        DeviceId(self.slots.len() - 1)
    }

    /// Adds a device while the engine runs: its clock's first rising edge comes one period after
    /// the last processed edge. It takes the place of a device that left at the same delay (and
    /// has no scope in a running trace), so devices coming and going do not grow the engine.
    pub fn join<D: Device>(&mut self, device: D, delay_fs: u64) -> DeviceId {
        let period = device.clock().period_fs();
        let clock = device.clock().with_phase(self.now + period);
        let free = (self.observers.traced_devices..self.slots.len())
            .find(|&i| self.slots[i].departed && self.bus.delay_fs(self.slots[i].line) == delay_fs);
        let Some(i) = free else {
            let id = self.add(device, delay_fs);
            let slot = &mut self.slots[id.0];
            slot.clock = clock;
            slot.next_edge = clock.edge(0);
            return id;
        };
        let slot = &mut self.slots[i];
        slot.probe_values = vec![0; device.probes().len()];
        slot.device = Box::new(device);
        slot.clock = clock;
        slot.edges = 0;
        slot.next_edge = clock.edge(0);
        slot.rx = true;
        slot.departed = false;
        self.forget_quiet();
        DeviceId(i)
    }

    /// Takes device `id` off the bus now: from here on it drives nothing and is not stepped. Its
    /// state stays readable through [`Engine::device`] until another device joins in its place.
    pub fn leave(&mut self, id: DeviceId) {
        let now = self.now;
        let slot = &mut self.slots[id.0];
        slot.departed = true;
        slot.next_edge = u64::MAX;
        slot.disturbances.clear();
        slot.overrides.clear();
        slot.pin = Drive::Recessive;
        slot.quiet_until = None;
        if slot.drive != Drive::Recessive {
            slot.drive = Drive::Recessive;
            let line = slot.line;
            self.bus.set_drive(line, now, Drive::Recessive);
            self.observers
                .expect_change_at(now + self.bus.delay_fs(line));
        }
    }

    /// Adds a bus line driven by a recording instead of a device (a replayed capture): what
    /// [`Engine::record_drive`] gives reaches the bus `delay_fs` later. Returns its line number.
    pub fn add_recorded_line(&mut self, delay_fs: u64) -> usize {
        self.bus.add_line(delay_fs)
    }

    /// Recorded line `line` drives `drive` from `t_fs` on; times never decrease per line and are
    /// not before the last processed edge.
    pub fn record_drive(&mut self, line: usize, t_fs: u64, drive: Drive) {
        debug_assert!(t_fs >= self.now, "a recording cannot change the past");
        self.forget_quiet();
        self.bus.set_drive(line, t_fs, drive);
        self.observers
            .expect_change_at(t_fs + self.bus.delay_fs(line));
    }

    /// Makes device `id` see `level` instead of the bus at its clock edges in `from_fs..to_fs` (the
    /// other devices and the bus are unaffected).
    pub fn disturb_rx(&mut self, id: DeviceId, from_fs: u64, to_fs: u64, level: bool) {
        self.forget_quiet();
        self.slots[id.0].disturbances.push(Disturbance {
            from_fs,
            to_fs,
            level: Some(level),
        });
    }

    /// Makes device `id` see the inverted bus level at its clock edges in `from_fs..to_fs`.
    pub fn invert_rx(&mut self, id: DeviceId, from_fs: u64, to_fs: u64) {
        self.forget_quiet();
        self.slots[id.0].disturbances.push(Disturbance {
            from_fs,
            to_fs,
            level: None,
        });
    }

    /// Replaces what device `id` puts on the bus by `drive` at its clock edges in `from_fs..to_fs`
    /// (a disconnected transmitter: [`Drive::Recessive`]; a stuck one: [`Drive::Dominant`]). The
    /// device's `tx` pin, as traced, is unaffected.
    pub fn override_drive(&mut self, id: DeviceId, from_fs: u64, to_fs: u64, drive: Drive) {
        self.forget_quiet();
        self.slots[id.0].overrides.push(DriveOverride {
            from_fs,
            to_fs,
            drive,
        });
    }

    /// Puts `fault` on the bus itself from `from_fs` to `to_fs` (every device sees it through its
    /// delay, and the traced `bus` shows it). The window must not begin in the past.
    pub fn fault_bus(&mut self, from_fs: u64, to_fs: u64, fault: BusFault) {
        self.forget_quiet();
        self.bus.add_fault(from_fs, to_fs, fault);
        self.observers.expect_change_at(from_fs);
        self.observers.expect_change_at(to_fs);
    }

    /// Traces `probe` beside `bus`, with the values `annotator` derives from the bus level
    /// changes; call before [`Engine::trace_vcd`].
    pub fn annotate_bus(&mut self, probe: Probe, annotator: BusAnnotator) {
        assert!(
            self.observers.tracer.is_none(),
            "annotate the bus before tracing starts"
        );
        self.observers.annotation = Some((probe, annotator));
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
        let bus_probes: Vec<Probe> = self.observers.annotation.iter().map(|(p, _)| *p).collect();
        self.observers.tracer = Some(VcdTracer::create(path, &bus_probes, &devices, timing)?);
        self.observers.traced_devices = devices.len();
        self.forget_quiet();
        Ok(())
    }

    /// Ends tracing: writes the rest of the VCD and moves it into place. Returns the path, if tracing.
    pub fn finish_trace(&mut self) -> io::Result<Option<std::path::PathBuf>> {
        self.flush_bus_changes(u64::MAX)?;
        self.forget_quiet();
        match self.observers.tracer.take() {
            Some(tracer) => tracer.finish(self.now).map(Some),
            None => Ok(None),
        }
    }

    /// Ends tracing without writing the VCD (a failed run): its temporary file is removed.
    pub fn discard_trace(&mut self) {
        self.observers.tracer = None;
        self.forget_quiet();
    }

    /// Starts recording the changes of the bus level for [`Engine::take_bus_changes`]; call before
    /// the first step.
    pub fn watch_bus(&mut self) {
        self.observers.changes = Some(Vec::new());
    }

    /// The bus level changes (time, new level) recorded since the last call, oldest first: every
    /// change before the last processed clock edge (needs [`Engine::watch_bus`]).
    pub fn take_bus_changes(&mut self) -> io::Result<Vec<(u64, bool)>> {
        self.flush_bus_changes(self.now)?;
        Ok(self
            .observers
            .changes
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default())
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

    /// Every change of what `id` drove, as (time, new drive), oldest first: the whole run with
    /// [`Engine::keep_history`], otherwise only the recent ones the bus still holds.
    pub fn drive_changes(&self, id: DeviceId) -> Vec<(u64, Drive)> {
        self.bus.drive_changes(self.slots[id.0].line).collect()
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
        self.slots[id.0].quiet_until = None;
        self.slots[id.0]
            .device
            .as_any_mut()
            .downcast_mut()
            .expect("device type does not match its id")
    }

    /// Time of the next clock edge the engine will process.
    pub fn next_edge(&self) -> Option<u64> {
        self.slots
            .iter()
            .map(|s| s.next_edge)
            .min()
            .filter(|&t| t != u64::MAX)
    }

    /// Processes the earliest pending clock edge (never skips: one edge).
    pub fn step(&mut self) -> io::Result<()> {
        // A deferred trace starts at the first `step` even when no edge is pending (the run loops
        // start it only when they step).
        self.start_deferred_trace()?;
        self.step_before(u64::MAX, false).map(|_| ())
    }

    /// Starts the trace asked for by [`Engine::trace_vcd_from_first_step`], if any.
    fn start_deferred_trace(&mut self) -> io::Result<()> {
        match self.deferred_trace.take() {
            Some((path, timing)) => self.start_trace(&path, Some(&timing)),
            None => Ok(()),
        }
    }

    /// Processes the earliest pending clock edge if it comes before `limit_fs`, or with
    /// `may_skip` the quiet edges from it on (when skipping); returns whether it did. One search
    /// for the earliest edge serves both the test and the step (the search looks at every device:
    /// a separate [`Engine::next_edge`] before each step doubled it).
    fn step_before(&mut self, limit_fs: u64, may_skip: bool) -> io::Result<bool> {
        let i = loop {
            let Some(i) = self.earliest() else {
                return Ok(false);
            };
            if self.slots[i].turn() >= limit_fs {
                return Ok(false);
            }
            self.start_deferred_trace()?;
            if self.slots[i].parked > 0 {
                self.jump_parked(i);
                return Ok(true);
            }
            let parks = may_skip && self.skipping != EdgeSkipping::Off;
            if !(parks && self.park_quiet_edges(i, limit_fs)) {
                break i;
            }
        };
        let t = self.slots[i].next_edge;
        self.flush_bus_changes(t)?;
        self.now = t;
        self.edges += 1;
        self.last_stepped = Some(DeviceId(i));
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
        let pin = slot.device.rising_edge(t, rx);
        let drive = slot.effective_drive(t, pin);
        slot.pin = pin;
        slot.rx = rx;
        slot.edges += 1;
        slot.next_edge = slot.clock.edge(slot.edges);
        slot.quiet_until = None;
        if drive != slot.drive {
            slot.drive = drive;
            self.bus.set_drive(line, t, drive);
            self.observers.expect_change_at(t + self.bus.delay_fs(line));
            self.forget_quiet();
            self.cut_parked(t);
        }
        let traced = i < self.observers.traced_devices;
        if let Some(tracer) = self.observers.tracer.as_mut().filter(|_| traced) {
            let slot = &mut self.slots[i];
            let tx = slot.pin.level();
            match slot.device.packed_probe_values() {
                Some(packed) => tracer.device_packed(i, t, tx, slot.rx, packed)?,
                None => {
                    slot.device.probe_values(&mut slot.probe_values);
                    tracer.device(i, t, tx, slot.rx, &slot.probe_values)?;
                }
            }
        }
        if self.edges.is_multiple_of(PRUNE_EDGES) {
            self.bus.prune(t);
        }
        Ok(true)
    }

    /// When device `i`, the earliest, has quiet edges ahead (at least two, before `limit_fs`, a
    /// bus fault's or its own disturbance's start or end): parks them, to be jumped over when the
    /// last of them comes first in time order ([`Engine::jump_parked`]), and returns true. Other
    /// devices go on stepping meanwhile; what they drive cannot change what device `i` does in
    /// those edges unless it changes the bus before them, and then the parked edges are cut back
    /// to those before the change ([`Engine::cut_parked`]). Only while the level every device sees
    /// is settled (no change on its way through a delay).
    fn park_quiet_edges(&mut self, i: usize, limit_fs: u64) -> bool {
        let next = self.slots[i].next_edge;
        if self.quiet_until(i) <= next.saturating_add(self.slots[i].clock.period_fs())
            || self.bus.settled_from() > next
        {
            return false;
        }
        let horizon = limit_fs
            .min(self.bus.next_fault_boundary(self.now))
            .min(self.quiet_until(i))
            .min(self.next_window_boundary(i));
        let edges = edges_before(&self.slots[i], horizon);
        if edges < 2 {
            return false;
        }
        self.slots[i].parked = edges;
        true
    }

    /// Jumps over device `i`'s parked edges in one step.
    fn jump_parked(&mut self, i: usize) {
        let checked = self.skipping == EdgeSkipping::Checked;
        let pruned_before = self.edges / PRUNE_EDGES;
        let traced = self.observers.tracer.is_some() && i < self.observers.traced_devices;
        let rx = self.rx_seen(i, self.slots[i].next_edge);
        let slot = &mut self.slots[i];
        let edges = std::mem::take(&mut slot.parked);
        slot.device.skip_edges(edges, rx, traced, checked);
        slot.edges += edges;
        slot.next_edge = slot.clock.edge(slot.edges);
        self.now = self.now.max(slot.clock.edge(slot.edges - 1));
        self.edges += edges;
        self.skipped += edges;
        self.last_stepped = Some(DeviceId(i));
        if self.edges / PRUNE_EDGES != pruned_before {
            self.bus.prune(self.now);
        }
    }

    /// The bus changes at `t`: parked edges after `t` are no longer quiet (a device sees a change
    /// only after it, `Bus::level_seen_by`).
    fn cut_parked(&mut self, t: u64) {
        for slot in &mut self.slots {
            if slot.parked > 0 {
                slot.parked = slot.parked.min(edges_before(slot, t.saturating_add(1)));
            }
        }
    }

    /// Jumps over the parked edges that stepping in time order would have processed by now (the
    /// last step was device `last`'s edge at `now`) and drops the others, so that a run returns
    /// with every device where stepping each edge would have left it.
    fn settle_parked(&mut self) {
        let last = self.last_stepped.map_or(0, |id| id.0);
        for i in 0..self.slots.len() {
            let slot = &mut self.slots[i];
            if slot.parked == 0 {
                continue;
            }
            // Edges at `now` itself come before the last one's when their device is earlier.
            let until = self.now.saturating_add(u64::from(i < last));
            slot.parked = slot.parked.min(edges_before(slot, until));
            if slot.parked > 0 {
                self.jump_parked(i);
            }
        }
        self.last_stepped = Some(DeviceId(last));
    }

    /// The time of device `j`'s first edge that is not quiet (its next edge if it has none).
    fn quiet_until(&mut self, j: usize) -> u64 {
        if let Some(t) = self.slots[j].quiet_until {
            return t;
        }
        let traced = self.observers.tracer.is_some() && j < self.observers.traced_devices;
        let slot = &self.slots[j];
        let t = if slot.departed {
            u64::MAX
        } else {
            let rx = self.rx_seen(j, slot.next_edge);
            let slot = &self.slots[j];
            let quiet = slot.device.quiet_edges(rx, traced);
            // A device quiet for as long as nothing changes may say so with a huge count.
            let edge = slot.edges.saturating_add(quiet);
            slot.clock
                .edge(0)
                .saturating_add(edge.saturating_mul(slot.clock.period_fs()))
        };
        self.slots[j].quiet_until = Some(t);
        t
    }

    /// The level device `j` sees at its edge at `t`: the bus, or a disturbance of its own.
    fn rx_seen(&self, j: usize, t: u64) -> bool {
        let slot = &self.slots[j];
        let bus = self.bus.level_seen_by(slot.line, t);
        match slot
            .disturbances
            .iter()
            .find(|d| (d.from_fs..d.to_fs).contains(&t))
        {
            Some(d) => d.level.unwrap_or(!bus),
            None => bus,
        }
    }

    /// The first start or end after the last processed edge of a window that changes what device
    /// `j` sees or drives.
    fn next_window_boundary(&self, j: usize) -> u64 {
        let slot = &self.slots[j];
        let disturbances = slot.disturbances.iter().map(|d| (d.from_fs, d.to_fs));
        let overrides = slot.overrides.iter().map(|o| (o.from_fs, o.to_fs));
        disturbances
            .chain(overrides)
            .flat_map(|(from, to)| [from, to])
            .filter(|&b| b > self.now)
            .min()
            .unwrap_or(u64::MAX)
    }

    /// Processes every clock edge before `t_fs`.
    pub fn run_until(&mut self, t_fs: u64) -> io::Result<()> {
        while self.step_before(t_fs, true)? {}
        Ok(())
    }

    /// Steps until device `id` has processed `count` more clock edges, as stepping edge by edge
    /// does (stopping right after that edge: other devices' edges at the same time that come
    /// after it in order wait), whether or not quiet edges are skipped on the way.
    pub fn run_edges(&mut self, id: DeviceId, count: u64) -> io::Result<()> {
        let slot = &self.slots[id.0];
        let end = slot.edges + count;
        if count == 0 || slot.departed {
            return Ok(());
        }
        let last = slot.clock.edge(end - 1);
        self.run_until(last)?;
        // Only edges at `last` remain before the device's: no room for a skip.
        while self.slots[id.0].edges < end && self.step_before(last + 1, false)? {}
        Ok(())
    }

    /// The device whose clock edge the last [`Engine::step`] processed: the only one whose outputs
    /// can have changed since (so a condition on every device's outputs can follow that one).
    pub fn last_stepped(&self) -> Option<DeviceId> {
        self.last_stepped
    }

    /// Steps until `done(self)` holds (checked after every edge) or `limit_fs` is reached. Returns
    /// whether `done` held.
    ///
    /// With quiet edges skipped, the first edge is always stepped (`done` may hold before it, and
    /// then it is asked right after that edge), the later ones only once `done` has not held after
    /// an edge: quiet edges change nothing `done` can look at but the time, so a condition on the
    /// time (`now()`) needs skipping off.
    pub fn run_while<F: FnMut(&Engine) -> bool>(
        &mut self,
        limit_fs: u64,
        mut done: F,
    ) -> io::Result<bool> {
        let mut may_skip = false;
        while self.step_before(limit_fs, may_skip)? {
            if done(self) {
                self.settle_parked();
                return Ok(true);
            }
            may_skip = true;
        }
        Ok(false)
    }

    fn earliest(&self) -> Option<usize> {
        let mut best: Option<(u64, usize)> = None;
        for (i, s) in self.slots.iter().enumerate() {
            let turn = s.turn();
            if best.is_none_or(|(t, _)| turn < t) {
                best = Some((turn, i));
            }
        }
        best.filter(|&(t, _)| t != u64::MAX).map(|(_, i)| i)
    }

    /// Reports the bus-level changes that happen before `t` to the tracer and the watch (changes at
    /// `t` itself wait, so that every device stepping at `t` has applied its drive first).
    fn flush_bus_changes(&mut self, t: u64) -> io::Result<()> {
        let observers = &mut self.observers;
        while let Some(&std::cmp::Reverse(at)) = observers.pending.peek() {
            if at >= t {
                break;
            }
            observers.pending.pop();
            let level = self.bus.level_before(at + 1);
            if observers.last == level {
                continue;
            }
            observers.last = level;
            if let Some(tracer) = &mut observers.tracer {
                tracer.bus(at, level)?;
                if let Some((_, annotator)) = &mut observers.annotation {
                    if let Some(value) = annotator(at, level) {
                        tracer.bus_probe(0, at, value)?;
                    }
                }
            }
            if let Some(changes) = &mut observers.changes {
                changes.push((at, level));
            }
        }
        Ok(())
    }
}

impl Drop for Engine {
    fn drop(&mut self) {
        if self.observers.tracer.is_some() {
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

    /// Toggles its drive at every `period`-th edge and records those edges and every change of
    /// what it sees; every other edge is quiet while the level it sees holds.
    struct Pulser {
        clock: ClockSpec,
        period: u64,
        edges: u64,
        seen: bool,
        drive: Drive,
        record: Vec<(u64, &'static str, bool)>,
    }

    impl Pulser {
        fn new(hz: f64, period: u64) -> Pulser {
            Pulser {
                clock: ClockSpec::from_hz(hz),
                period,
                edges: 0,
                seen: RECESSIVE,
                drive: Drive::Recessive,
                record: Vec::new(),
            }
        }
    }

    impl Device for Pulser {
        fn name(&self) -> &str {
            "pulser"
        }
        fn clock(&self) -> ClockSpec {
            self.clock
        }
        fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive {
            self.edges += 1;
            if rx != self.seen {
                self.seen = rx;
                self.record.push((t_fs, "sees", rx));
            }
            if self.edges.is_multiple_of(self.period) {
                self.drive = Drive::from_level(!self.drive.level());
                self.record.push((t_fs, "drives", self.drive.level()));
            }
            self.drive
        }
        fn quiet_edges(&self, rx: bool, _traced: bool) -> u64 {
            if rx == self.seen {
                self.period - 1 - self.edges % self.period
            } else {
                0
            }
        }
        fn skip_edges(&mut self, edges: u64, _rx: bool, _traced: bool, _checked: bool) {
            assert!(
                edges <= self.quiet_edges(self.seen, false),
                "a skip past an event"
            );
            self.edges += edges;
        }
        fn as_any(&self) -> &dyn Any {
            self
        }
        fn as_any_mut(&mut self) -> &mut dyn Any {
            self
        }
    }

    /// Three pulsers on different clocks (one behind a delay), run to the same time.
    fn pulsers(skipping: EdgeSkipping) -> Engine {
        let mut engine = Engine::new();
        engine.set_edge_skipping(skipping);
        engine.add(Pulser::new(1e6, 7), 0);
        engine.add(Pulser::new(1.3e6, 11), 250_000);
        engine.add(Pulser::new(0.7e6, 5), 0);
        engine.run_until(200 * 1_000_000_000).unwrap();
        engine
    }

    #[test]
    fn skipping_quiet_edges_gives_the_same_edges_drives_and_levels_as_stepping_them() {
        let (plain, skipping) = (pulsers(EdgeSkipping::Off), pulsers(EdgeSkipping::On));
        assert_eq!(plain.skipped_edges(), 0);
        assert!(
            skipping.skipped_edges() > skipping.edges() / 2,
            "{} of {} skipped",
            skipping.skipped_edges(),
            skipping.edges()
        );
        assert_eq!(plain.edges(), skipping.edges());
        assert_eq!(plain.now(), skipping.now());
        for k in 0..3 {
            let (a, b) = (
                plain.device::<Pulser>(DeviceId(k)),
                skipping.device::<Pulser>(DeviceId(k)),
            );
            assert!(a.record.len() > 10, "pulser {k}: {:?}", a.record);
            assert_eq!(a.record, b.record, "pulser {k}");
            assert_eq!(a.edges, b.edges, "pulser {k}");
        }
    }

    /// A pulser behind a delay changes its drive 100 ns before the other's edge: that edge still
    /// sees the old level, the next ones the new level, skipped or not.
    #[test]
    fn a_level_on_its_way_through_a_delay_is_seen_when_it_arrives_with_edges_skipped() {
        let run = |skipping| {
            let mut engine = Engine::new();
            engine.set_edge_skipping(skipping);
            let mut sender = Pulser::new(1e6, 4);
            let mut listener = Pulser::new(1e6, 1000);
            listener.clock = listener.clock.with_phase(100_000_000);
            sender.clock = sender.clock.with_phase(0);
            engine.add(sender, 500_000_000);
            engine.add(listener, 0);
            engine.run_until(100 * 1_000_000_000).unwrap();
            (
                engine.device::<Pulser>(DeviceId(1)).record.clone(),
                engine.skipped_edges(),
            )
        };
        let ((plain, _), (skipped, skips)) = (run(EdgeSkipping::Off), run(EdgeSkipping::On));
        assert!(skips > 0);
        assert!(plain.len() > 10, "{plain:?}");
        assert_eq!(plain, skipped);
    }

    /// `run_while` stops after the edge at which its condition holds (here the probe's 40th, which
    /// steps every edge); every other device has then run the edges that stepping runs by that
    /// time (its parked quiet edges before it jumped over, the later ones not), skipped or not.
    #[test]
    fn a_run_while_leaves_every_device_where_stepping_does() {
        let run = |skipping| {
            let mut engine = Engine::new();
            engine.set_edge_skipping(skipping);
            engine.add(Pulser::new(1.3e6, 11), 250_000);
            let watched = engine.add(probe(Drive::Recessive), 0);
            engine.add(Pulser::new(0.7e6, 13), 0);
            let done = |e: &Engine| e.device::<Probe>(watched).seen.len() >= 40;
            assert!(engine.run_while(u64::MAX, done).unwrap());
            let pulsers = [DeviceId(0), DeviceId(2)];
            let edges = pulsers.map(|id| engine.device::<Pulser>(id).edges);
            (edges, engine.now(), engine.skipped_edges())
        };
        let ((plain, plain_now, _), (skipped, now, skips)) =
            (run(EdgeSkipping::Off), run(EdgeSkipping::On));
        assert!(skips > 0);
        assert_eq!(plain, skipped);
        assert_eq!(plain_now, now);
    }

    #[test]
    fn running_a_device_s_edges_stops_after_its_last_one_as_stepping_does() {
        for skipping in [EdgeSkipping::Off, EdgeSkipping::On] {
            let mut engine = Engine::new();
            engine.set_edge_skipping(skipping);
            // The same clock: edges at the same times, taken in the order the devices came.
            let first = engine.add(Pulser::new(1e6, 50), 0);
            let second = engine.add(Pulser::new(1e6, 50), 0);
            let third = engine.add(Pulser::new(1e6, 50), 0);
            engine.run_edges(second, 40).unwrap();
            let edges = |id| engine.device::<Pulser>(id).edges;
            assert_eq!(
                (edges(first), edges(second), edges(third)),
                (40, 40, 39),
                "{skipping:?}"
            );
        }
    }

    #[test]
    fn skipping_modes_parse_and_anything_else_is_refused_with_the_allowed_values() {
        for mode in [EdgeSkipping::Off, EdgeSkipping::On, EdgeSkipping::Checked] {
            assert_eq!(mode.name().parse::<EdgeSkipping>(), Ok(mode));
        }
        assert_eq!("".parse::<EdgeSkipping>(), Ok(EdgeSkipping::Off));
        let refused = "yes".parse::<EdgeSkipping>().unwrap_err();
        assert_eq!(
            refused,
            "`yes` is not an edge skipping mode: use `off` (the default), `on` or `checked`"
        );
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
    fn a_device_joins_on_its_next_period_and_leaving_frees_the_bus_and_its_place() {
        let mut engine = Engine::new();
        let watcher = engine.add(probe(Drive::Recessive), 0);
        let us = ClockSpec::from_hz(1e6).period_fs();
        engine.run_until(3 * us + 1).unwrap();
        let dominant = engine.join(probe(Drive::Dominant), 0);
        assert_eq!(
            engine.next_edge(),
            Some(4 * us),
            "the watcher's edge 4 comes first"
        );
        engine.run_until(6 * us + 1).unwrap();
        // The newcomer's first edge is at 4 us (one period after the last edge, at 3 us); its
        // dominant level is on the bus from then on.
        assert_eq!(engine.device::<Probe>(dominant).seen, [true, false, false]);
        engine.leave(dominant);
        engine.run_until(9 * us + 1).unwrap();
        let seen = &engine.device::<Probe>(watcher).seen;
        assert_eq!(
            seen,
            &[true, true, true, true, true, false, false, true, true, true]
        );
        assert_eq!(
            engine.device::<Probe>(dominant).seen.len(),
            3,
            "no longer stepped"
        );
        let again = engine.join(probe(Drive::Recessive), 0);
        assert_eq!(
            again, dominant,
            "the place of the device that left is taken again"
        );
        engine.leave(watcher);
        engine.leave(again);
        assert_eq!(engine.next_edge(), None);
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
            text.contains(&crate::engine::bus_timing::timing_comment(&timing)),
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

    #[test]
    fn drive_overrides_and_bus_faults_reach_everyone_and_the_watch() {
        let mut engine = Engine::new();
        let stuck = engine.add(probe(Drive::Recessive), 0);
        let listener = engine.add(probe(Drive::Recessive), 0);
        let us = ClockSpec::from_hz(1e6).period_fs();
        engine.watch_bus();
        // The first device's transmitter is stuck dominant at its edges 2 and 3; the bus is
        // forced dominant for edges 6 and 7 (strictly after 5 µs, up to 7 µs).
        engine.override_drive(stuck, 2 * us, 4 * us, Drive::Dominant);
        engine.fault_bus(5 * us, 7 * us, BusFault::Force(golden::frame::DOMINANT));
        engine.run_until(10 * us).unwrap();
        let expected: Vec<bool> = (0..10).map(|k| !matches!(k, 3 | 4 | 6 | 7)).collect();
        assert_eq!(engine.device::<Probe>(listener).seen, expected);
        assert_eq!(
            engine.take_bus_changes().unwrap(),
            [
                (2 * us, false),
                (4 * us, true),
                (5 * us, false),
                (7 * us, true)
            ]
        );
        assert!(engine.take_bus_changes().unwrap().is_empty());
    }
}
