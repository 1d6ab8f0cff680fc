//! A bus node made of the RTL [`rtl::can_core::CanCore`] (bit timing logic + protocol engine), driven
//! through the core's internal interface the way the SJA1000 register block will drive it: a transmit
//! buffer in the SJA1000 frame-buffer layout with a request line, and the received-frame header, data
//! byte stream and validity strobe collected into frames.
//!
//! Stepping: inputs (including the transmit-buffer byte the core addresses) are applied with the clock
//! low and settled, then the rising edge is settled; the strobes seen after the edge are collected.

use std::any::Any;

use rtl::bsp::protocol::ProtocolState;
use rtl::can_core::CanCore;
use rust_hdl::prelude::*;

use crate::engine::bus::Drive;
use crate::engine::rtl_step::clock_cycle_with;
use crate::engine::time::ClockSpec;
use crate::engine::trace::Probe;
use crate::engine::Device;
use crate::host::frame_buffer::{encode_buffer, FRAME_BUFFER_BYTES};
use golden::btr::Btr;
use golden::frame::{Frame, Id};

/// Something the node reported, with the time of the clock edge after which it was seen.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum NodeEvent {
    /// A frame was received (validity point reached).
    Received(Frame),
    /// The transmit request ended; `true` if the frame was sent.
    TransmitDone(bool),
    /// A bus error with its SJA1000 ECC value.
    BusError(u8),
    /// Arbitration lost at this SJA1000 ALC position.
    ArbitrationLost(u8),
}

/// The RTL CAN core as a bus [`Device`].
pub struct CanNode {
    name: String,
    clock: ClockSpec,
    uut: CanCore,
    tx_buffer: [u8; FRAME_BUFFER_BYTES],
    rx_data: [u8; 8],
    events: Vec<(u64, NodeEvent)>,
    pending_load: Option<(bool, u8)>,
    pending_abort: bool,
    request_pending: bool,
    /// An input was changed since the last clock edge (the design needs an input settle).
    inputs_changed: bool,
}

impl CanNode {
    /// A node on `clock` with bit timing `btr`, reset, operating, error warning limit 96.
    pub fn new(name: &str, clock: ClockSpec, btr: Btr) -> CanNode {
        let mut uut = CanCore::default();
        uut.connect_all();
        uut.brp.next = (btr.brp as u64).to_bits();
        uut.tseg1.next = (btr.tseg1 as u64).to_bits();
        uut.tseg2.next = (btr.tseg2 as u64).to_bits();
        uut.sjw.next = (btr.sjw as u64).to_bits();
        uut.sam.next = btr.sam;
        uut.rx.next = true;
        uut.enable.next = true;
        uut.reset.next = true;
        let mut node = CanNode {
            name: name.to_string(),
            clock,
            uut,
            tx_buffer: [0; FRAME_BUFFER_BYTES],
            rx_data: [0; 8],
            events: Vec::new(),
            pending_load: None,
            pending_abort: false,
            request_pending: false,
            inputs_changed: true,
        };
        node.clock_edge();
        node.uut.reset.next = false;
        node.inputs_changed = true;
        node
    }

    /// Puts `frame` into the transmit buffer and requests its transmission (with automatic
    /// retransmission, or one attempt only with `single_shot`).
    pub fn send(&mut self, frame: &Frame, single_shot: bool) {
        assert!(
            !self.request_pending,
            "{}: a transmission is already pending",
            self.name
        );
        self.request_pending = true;
        self.tx_buffer = encode_buffer(frame);
        self.uut.transmit.info.next = (self.tx_buffer[0] as u64).to_bits();
        self.uut.transmit.single_shot.next = single_shot;
        self.uut.transmit.request.next = true;
        self.inputs_changed = true;
    }

    /// Aborts the pending request at the next clock edge (SJA1000 CMR.AT): a frame not under
    /// transmission is not sent (`TransmitDone(false)` follows); an attempt under way finishes and is
    /// not retried.
    pub fn abort(&mut self) {
        self.pending_abort = true;
    }

    /// Whether a transmission request is pending.
    pub fn transmit_pending(&self) -> bool {
        self.request_pending
    }

    /// Operating mode (`true`) or SJA1000 reset mode (`false`).
    pub fn set_enable(&mut self, enable: bool) {
        self.uut.enable.next = enable;
        self.inputs_changed = true;
    }

    /// Loads TEC (`tec` = true) or REC at the next clock edge, like a host write in reset mode.
    pub fn load_counter(&mut self, tec: bool, value: u8) {
        self.pending_load = Some((tec, value));
    }

    /// Everything the node reported, oldest first.
    pub fn events(&self) -> &[(u64, NodeEvent)] {
        &self.events
    }

    /// The frames received, in order.
    pub fn received(&self) -> Vec<Frame> {
        self.events
            .iter()
            .filter_map(|(_, e)| match e {
                NodeEvent::Received(f) => Some(*f),
                _ => None,
            })
            .collect()
    }

    /// The ECC values of the bus errors seen, in order.
    pub fn bus_errors(&self) -> Vec<u8> {
        self.events
            .iter()
            .filter_map(|(_, e)| match e {
                NodeEvent::BusError(ecc) => Some(*ecc),
                _ => None,
            })
            .collect()
    }

    /// Forgets the recorded events.
    pub fn clear_events(&mut self) {
        self.events.clear();
    }

    /// Transmit error counter.
    pub fn tec(&self) -> u8 {
        self.uut.status.tec.val().to_u8()
    }

    /// Receive error counter.
    pub fn rec(&self) -> u8 {
        self.uut.status.rec.val().to_u8()
    }

    /// Error passive.
    pub fn error_passive(&self) -> bool {
        self.uut.status.error_passive.val()
    }

    /// Bus-off.
    pub fn bus_off(&self) -> bool {
        self.uut.status.bus_off.val()
    }

    /// Protocol state.
    pub fn state(&self) -> ProtocolState {
        self.uut.status.state.val()
    }

    fn clock_edge(&mut self) {
        let changed = std::mem::take(&mut self.inputs_changed);
        clock_cycle_with(&mut self.uut, |u| &mut u.clock, "CAN core", changed);
    }

    /// Collects the strobes of the clock cycle that started at `t_fs`: errors first, then the
    /// frame and transmission results they may have caused.
    fn collect(&mut self, t_fs: u64) {
        let u = &self.uut;
        if u.status.bus_error.val() {
            self.events
                .push((t_fs, NodeEvent::BusError(u.status.ecc.val().to_u8())));
        }
        if u.status.arbitration_lost.val() {
            self.events
                .push((t_fs, NodeEvent::ArbitrationLost(u.status.alc.val().to_u8())));
        }
        if u.rx_frame.strobe.val() {
            self.rx_data[u.rx_frame.index.val().index()] = u.rx_frame.data.val().to_u8();
        }
        if u.rx_valid.val() {
            let frame = self.received_frame();
            self.events.push((t_fs, NodeEvent::Received(frame)));
        }
        if self.uut.transmit.done.val() {
            let success = self.uut.transmit.success.val();
            self.events.push((t_fs, NodeEvent::TransmitDone(success)));
            self.uut.transmit.request.next = false;
            self.inputs_changed = true;
            self.request_pending = false;
        }
    }

    fn received_frame(&self) -> Frame {
        let u = &self.uut;
        let raw = u.rx_frame.id.val().to_u32();
        let id = if u.rx_frame.ide.val() {
            Id::extended(raw)
        } else {
            Id::standard(raw as u16)
        }
        .expect("the core delivers identifiers in range");
        let dlc = u.rx_frame.dlc.val().to_u8();
        let frame = if u.rx_frame.rtr.val() {
            Frame::remote(id, dlc)
        } else {
            Frame::data_with_dlc(id, dlc, &self.rx_data[..dlc.min(8) as usize])
        };
        frame.expect("the core delivers DLC 0..15")
    }
}

impl Device for CanNode {
    fn name(&self) -> &str {
        &self.name
    }

    fn clock(&self) -> ClockSpec {
        self.clock
    }

    fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive {
        let addr = self.uut.transmit.addr.val().index();
        let tx_data = (self.tx_buffer.get(addr).copied().unwrap_or(0) as u64).to_bits();
        self.inputs_changed |= rx != self.uut.rx.val() || tx_data != self.uut.transmit.data.val();
        self.uut.rx.next = rx;
        self.uut.transmit.data.next = tx_data;
        let load = self.pending_load.take();
        let abort = std::mem::take(&mut self.pending_abort);
        let strobes = load.is_some() || abort;
        if strobes {
            self.uut.counters.load_tec.next = matches!(load, Some((true, _)));
            self.uut.counters.load_rec.next = matches!(load, Some((false, _)));
            self.uut.counters.value.next = (load.map_or(0, |(_, v)| v) as u64).to_bits();
            self.uut.transmit.abort.next = abort;
            self.inputs_changed = true;
        }
        self.clock_edge();
        if strobes {
            self.uut.counters.load_tec.next = false;
            self.uut.counters.load_rec.next = false;
            self.uut.transmit.abort.next = false;
            self.inputs_changed = true;
        }
        self.collect(t_fs);
        Drive::from_level(self.uut.tx.val())
    }

    fn probes(&self) -> Vec<Probe> {
        let mut probes = core_probes();
        probes.extend([Probe::bit("error_passive"), Probe::bit("bus_off")]);
        probes
    }

    fn probe_values(&self, values: &mut [u64]) {
        let u = &self.uut;
        let (core, own) = values.split_at_mut(CORE_PROBES);
        core_probe_values(u, core);
        own.copy_from_slice(&[
            u.status.error_passive.val() as u64,
            u.status.bus_off.val() as u64,
        ]);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// How many probes [`core_probes`] lists.
pub(crate) const CORE_PROBES: usize = 5;

/// The probes every device built on the RTL core traces: sample point, bit timing segment, protocol
/// state, TEC, REC.
pub(crate) fn core_probes() -> Vec<Probe> {
    vec![
        Probe::bit("sample_point"),
        Probe {
            name: "segment",
            width: 2,
        },
        Probe {
            name: "state",
            width: 5,
        },
        Probe {
            name: "tec",
            width: 8,
        },
        Probe {
            name: "rec",
            width: 8,
        },
    ]
}

/// The values of [`core_probes`] for `core`.
pub(crate) fn core_probe_values(core: &CanCore, values: &mut [u64]) {
    values.copy_from_slice(&[
        core.sample_point.val() as u64,
        core.segment.val() as u64,
        core.status.state.val() as u64,
        core.status.tec.val().to_u64(),
        core.status.rec.val().to_u64(),
    ]);
}
