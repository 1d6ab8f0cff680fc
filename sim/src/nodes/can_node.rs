//! A bus node made of the RTL [`rtl::can_core::CanCore`] (bit timing logic + protocol engine), driven
//! through the core's internal interface the way the SJA1000 register block will drive it: a transmit
//! buffer in the SJA1000 frame-buffer layout with a request line, and the received-frame header, data
//! byte stream and validity strobe collected into frames.
//!
//! Stepping: inputs (including the transmit-buffer byte the core addresses) are applied with the clock
//! low and settled, then the rising edge is settled; the strobes seen after the edge are collected.
//! The core runs on the engine `CAN_ENGINE` names ([`crate::nodes::core_engine`]).

use std::any::Any;

use rtl::bsp::protocol::ProtocolState;
use rtl::bsp::received_frame::STANDARD_ID_SHIFT;

use crate::engine::bus::Drive;
use crate::engine::time::ClockSpec;
use crate::engine::trace::Probe;
use crate::engine::Device;
use crate::host::frame_buffer::{encode_buffer, FRAME_BUFFER_BYTES};
use crate::nodes::controller_node::ModelEngine;
use crate::nodes::core_engine::{CoreInputs, CoreModel, CoreOutputs};
use crate::verilated::EngineError;
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
    core: CoreModel,
    /// The inputs of the next clock cycle.
    inputs: CoreInputs,
    /// The outputs after the last clock edge.
    out: CoreOutputs,
    tx_buffer: [u8; FRAME_BUFFER_BYTES],
    rx_data: [u8; 8],
    events: Vec<(u64, NodeEvent)>,
    pending_load: Option<(bool, u8)>,
    pending_abort: bool,
    request_pending: bool,
}

impl CanNode {
    /// A node on `clock` with bit timing `btr`, reset, operating, error warning limit 96, on the
    /// engine `CAN_ENGINE` names; panics with the reason if that engine cannot run (see
    /// [`CanNode::with_engine`]).
    pub fn new(name: &str, clock: ClockSpec, btr: Btr) -> CanNode {
        let engine = ModelEngine::from_env().unwrap_or_else(|e| panic!("{e}"));
        CanNode::with_engine(name, clock, btr, engine).unwrap_or_else(|e| panic!("{name}: {e}"))
    }

    /// A node as [`CanNode::new`] makes it, on `engine`.
    pub fn with_engine(
        name: &str,
        clock: ClockSpec,
        btr: Btr,
        engine: ModelEngine,
    ) -> Result<CanNode, EngineError> {
        let mut core = CoreModel::new(engine)?;
        let mut inputs = CoreInputs {
            reset: true,
            rx: true,
            enable: true,
            brp: btr.brp,
            tseg1: btr.tseg1,
            tseg2: btr.tseg2,
            sjw: btr.sjw,
            sam: btr.sam,
            ..CoreInputs::default()
        };
        let out = core.cycle(&inputs);
        inputs.reset = false;
        Ok(CanNode {
            name: name.to_string(),
            clock,
            core,
            inputs,
            out,
            tx_buffer: [0; FRAME_BUFFER_BYTES],
            rx_data: [0; 8],
            events: Vec::new(),
            pending_load: None,
            pending_abort: false,
            request_pending: false,
        })
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
        self.inputs.info = self.tx_buffer[0];
        self.inputs.single_shot = single_shot;
        self.inputs.request = true;
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
        self.inputs.enable = enable;
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
        self.out.tec
    }

    /// Receive error counter.
    pub fn rec(&self) -> u8 {
        self.out.rec
    }

    /// Error passive.
    pub fn error_passive(&self) -> bool {
        self.out.error_passive
    }

    /// Bus-off.
    pub fn bus_off(&self) -> bool {
        self.out.bus_off
    }

    /// Protocol state.
    pub fn state(&self) -> ProtocolState {
        self.out.state
    }

    /// The inputs of an edge without a counter load or abort at which the node sees `rx`.
    fn idle_inputs(&self, rx: bool) -> CoreInputs {
        CoreInputs {
            rx,
            data: self
                .tx_buffer
                .get(usize::from(self.out.tx_addr))
                .copied()
                .unwrap_or(0),
            load_tec: false,
            load_rec: false,
            value: 0,
            abort: false,
            ..self.inputs
        }
    }

    /// Records the strobes of the clock cycle that started at `t_fs` ([`cycle_events`]); a
    /// finished transmission ends the request.
    fn collect(&mut self, t_fs: u64) {
        let (events, request_pending) = (&mut self.events, &mut self.request_pending);
        cycle_events(&self.out, &mut self.rx_data, |event| {
            if matches!(event, NodeEvent::TransmitDone(_)) {
                *request_pending = false;
            }
            events.push((t_fs, event));
        });
        if !self.request_pending {
            self.inputs.request = false;
        }
    }
}

/// Reports the strobes among one cycle's outputs `out` in the order a node records them: errors
/// first, then the frame and transmission results they may have caused; `rx_data` collects the
/// received data bytes as they are strobed.
pub(crate) fn cycle_events(
    out: &CoreOutputs,
    rx_data: &mut [u8; 8],
    mut report: impl FnMut(NodeEvent),
) {
    if out.bus_error {
        report(NodeEvent::BusError(out.ecc));
    }
    if out.arbitration_lost {
        report(NodeEvent::ArbitrationLost(out.alc));
    }
    if out.rx_strobe {
        rx_data[usize::from(out.rx_index)] = out.rx_data;
    }
    if out.rx_valid {
        report(NodeEvent::Received(received_frame(out, rx_data)));
    }
    if out.tx_done {
        report(NodeEvent::TransmitDone(out.tx_success));
    }
}

/// The frame a core with outputs `out` delivers, its data bytes collected in `rx_data`.
fn received_frame(out: &CoreOutputs, rx_data: &[u8; 8]) -> Frame {
    let raw = out.rx_id;
    let id = if out.rx_ide {
        Id::extended(raw)
    } else {
        Id::standard((raw >> STANDARD_ID_SHIFT) as u16)
    }
    .expect("the core delivers identifiers in range");
    let dlc = out.rx_dlc;
    let frame = if out.rx_rtr {
        Frame::remote(id, dlc)
    } else {
        Frame::data_with_dlc(id, dlc, &rx_data[..dlc.min(8) as usize])
    };
    frame.expect("the core delivers DLC 0..15")
}

impl Device for CanNode {
    fn name(&self) -> &str {
        &self.name
    }

    fn clock(&self) -> ClockSpec {
        self.clock
    }

    fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive {
        let addr = usize::from(self.out.tx_addr);
        self.inputs.rx = rx;
        self.inputs.data = self.tx_buffer.get(addr).copied().unwrap_or(0);
        let load = self.pending_load.take();
        let abort = std::mem::take(&mut self.pending_abort);
        self.inputs.load_tec = matches!(load, Some((true, _)));
        self.inputs.load_rec = matches!(load, Some((false, _)));
        self.inputs.value = load.map_or(0, |(_, v)| v);
        self.inputs.abort = abort;
        self.out = self.core.cycle(&self.inputs);
        self.collect(t_fs);
        Drive::from_level(self.out.tx)
    }

    fn quiet_edges(&self, rx: bool, traced: bool) -> u64 {
        let out = &self.out;
        let pulses = out.bus_error || out.arbitration_lost || out.rx_strobe || out.rx_valid;
        if pulses || out.tx_done || self.pending_load.is_some() || self.pending_abort {
            return 0;
        }
        self.core.quiet_cycles(&self.idle_inputs(rx), traced)
    }

    fn skip_edges(&mut self, edges: u64, rx: bool, traced: bool, checked: bool) {
        self.inputs = self.idle_inputs(rx);
        self.core.skip(edges, traced, checked);
    }

    fn probes(&self) -> Vec<Probe> {
        let mut probes = core_probes();
        probes.extend([Probe::bit("error_passive"), Probe::bit("bus_off")]);
        probes
    }

    fn probe_values(&self, values: &mut [u64]) {
        let (core, own) = values.split_at_mut(CORE_PROBES);
        core_probe_values(&self.out, core);
        own.copy_from_slice(&[
            u64::from(self.out.error_passive),
            u64::from(self.out.bus_off),
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

/// Their widths added up.
pub(crate) const CORE_PROBE_BITS: u32 = 24;

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

/// The values of [`core_probes`] for a core with outputs `out`.
pub(crate) fn core_probe_values(out: &CoreOutputs, values: &mut [u64]) {
    values.copy_from_slice(&[
        u64::from(out.sample_point),
        u64::from(out.segment),
        out.state as u64,
        u64::from(out.tec),
        u64::from(out.rec),
    ]);
}
