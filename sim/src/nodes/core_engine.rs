//! The CAN core ([`rtl::can_core::CanCore`]) stepped by one of the engines: its ports as plain values
//! ([`CoreInputs`] in, [`CoreOutputs`] out) and one clock cycle per call. The rust-hdl model and the
//! compiled model ([`crate::compiled::core`]) give the same outputs cycle for cycle (the engines
//! test). There is no Verilator model of the bare core: under `CAN_ENGINE=verilator` it runs
//! compiled.

use rtl::activity::Child as _;
use rtl::bsp::protocol::ProtocolState;
use rtl::can_core::CanCore;
use rust_hdl::prelude::*;

use crate::compiled::core::CompiledCore;
use crate::engine::rtl_step::clock_cycle_with;
use crate::nodes::controller_node::ModelEngine;
use crate::verilated::EngineError;

/// The core's inputs during one clock cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CoreInputs {
    /// Synchronous reset.
    pub reset: bool,
    /// Bus input.
    pub rx: bool,
    /// Operating mode (low: SJA1000 reset mode).
    pub enable: bool,
    /// BTR0.5..0.
    pub brp: u8,
    /// BTR1.3..0.
    pub tseg1: u8,
    /// BTR1.6..4.
    pub tseg2: u8,
    /// BTR0.7..6.
    pub sjw: u8,
    /// BTR1.7 (triple sampling).
    pub sam: bool,
    /// MOD.LOM.
    pub listen_only: bool,
    /// MOD.STM.
    pub self_test: bool,
    /// A frame waits in the transmit buffer.
    pub request: bool,
    /// One attempt only.
    pub single_shot: bool,
    /// Abort the request (one clock).
    pub abort: bool,
    /// Frame information byte of the frame to send.
    pub info: u8,
    /// The transmit-buffer byte at the core's `tx_addr`.
    pub data: u8,
    /// Load `value` into TEC (one clock).
    pub load_tec: bool,
    /// Load `value` into REC (one clock).
    pub load_rec: bool,
    /// The counter value loaded.
    pub value: u8,
}

/// The core's outputs after a clock edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoreOutputs {
    /// Bus output.
    pub tx: bool,
    /// A received frame is valid (one clock).
    pub rx_valid: bool,
    /// The transmit-buffer byte wanted.
    pub tx_addr: u8,
    /// The transmit request ended (one clock).
    pub tx_done: bool,
    /// With `tx_done`: the frame was sent.
    pub tx_success: bool,
    /// The received header is complete (one clock).
    pub rx_header: bool,
    /// Received identifier, as the stream carries it (a standard one shifted up by
    /// `rtl::bsp::received_frame::STANDARD_ID_SHIFT`).
    pub rx_id: u32,
    /// Received IDE.
    pub rx_ide: bool,
    /// Received RTR.
    pub rx_rtr: bool,
    /// Received DLC.
    pub rx_dlc: u8,
    /// A received data byte (one clock).
    pub rx_strobe: bool,
    /// The data byte.
    pub rx_data: u8,
    /// Its index.
    pub rx_index: u8,
    /// A bus error was detected (one clock).
    pub bus_error: bool,
    /// SJA1000 error code capture.
    pub ecc: u8,
    /// Arbitration was lost (one clock).
    pub arbitration_lost: bool,
    /// SJA1000 arbitration lost capture.
    pub alc: u8,
    /// Transmit error counter.
    pub tec: u8,
    /// Receive error counter.
    pub rec: u8,
    /// Error passive.
    pub error_passive: bool,
    /// Bus-off.
    pub bus_off: bool,
    /// Transmitting a frame of its own.
    pub transmitting: bool,
    /// Receiving a frame.
    pub receiving: bool,
    /// Protocol state.
    pub state: ProtocolState,
    /// Sample point trigger.
    pub sample_point: bool,
    /// Bit timing segment.
    pub segment: u8,
}

/// A CAN core on one engine.
pub enum CoreModel {
    /// The rust-hdl model; `applied` holds the inputs of the last cycle.
    RustHdl {
        /// The model.
        uut: Box<CanCore>,
        /// The inputs it holds (`None` before the first cycle).
        applied: Option<CoreInputs>,
    },
    /// The compiled model.
    Compiled(CompiledCore),
}

impl CoreModel {
    /// A core at power-up on `engine` (Verilator: compiled, see the module doc).
    pub fn new(engine: ModelEngine) -> Result<CoreModel, EngineError> {
        Ok(match engine {
            ModelEngine::RustHdl | ModelEngine::RustHdlExhaustive => {
                let mut uut = Box::<CanCore>::default();
                uut.connect_all();
                uut.set_exhaustive(engine == ModelEngine::RustHdlExhaustive);
                CoreModel::RustHdl { uut, applied: None }
            }
            ModelEngine::Compiled | ModelEngine::Verilator => {
                CoreModel::Compiled(CompiledCore::new(false)?)
            }
            ModelEngine::CompiledExhaustive => CoreModel::Compiled(CompiledCore::new(true)?),
        })
    }

    /// One clock cycle: `inputs` applied, the rising edge, the outputs with the clock low again.
    pub fn cycle(&mut self, inputs: &CoreInputs) -> CoreOutputs {
        match self {
            CoreModel::RustHdl { uut, applied } => {
                let changed = *applied != Some(*inputs);
                if changed {
                    apply(uut, inputs);
                    *applied = Some(*inputs);
                }
                clock_cycle_with(&mut **uut, |u| &mut u.clock, "CAN core", changed);
                CoreOutputs::of(uut)
            }
            CoreModel::Compiled(core) => core.cycle(inputs),
        }
    }

    /// Quiet cycles ahead with `inputs` ([`CompiledCore::quiet_cycles`]); none on rust-hdl.
    pub fn quiet_cycles(&self, inputs: &CoreInputs, traced: bool) -> u64 {
        match self {
            CoreModel::RustHdl { .. } => 0,
            CoreModel::Compiled(core) => core.quiet_cycles(inputs, traced),
        }
    }

    /// Runs `cycles` quiet cycles at once ([`CompiledCore::skip`]).
    pub fn skip(&mut self, cycles: u64, traced: bool, checked: bool) {
        match self {
            CoreModel::RustHdl { .. } => unreachable!("the rust-hdl core has no quiet cycles"),
            CoreModel::Compiled(core) => core.skip(cycles, traced, checked),
        }
    }
}

fn bits<const N: usize>(value: u8) -> Bits<N> {
    u64::from(value).to_bits()
}

fn apply(u: &mut CanCore, i: &CoreInputs) {
    u.reset.next = i.reset;
    u.rx.next = i.rx;
    u.enable.next = i.enable;
    u.brp.next = bits(i.brp);
    u.tseg1.next = bits(i.tseg1);
    u.tseg2.next = bits(i.tseg2);
    u.sjw.next = bits(i.sjw);
    u.sam.next = i.sam;
    u.listen_only.next = i.listen_only;
    u.self_test.next = i.self_test;
    u.transmit.request.next = i.request;
    u.transmit.single_shot.next = i.single_shot;
    u.transmit.abort.next = i.abort;
    u.transmit.info.next = bits(i.info);
    u.transmit.data.next = bits(i.data);
    u.counters.load_tec.next = i.load_tec;
    u.counters.load_rec.next = i.load_rec;
    u.counters.value.next = bits(i.value);
}

impl CoreOutputs {
    /// The outputs of the rust-hdl core `u` now.
    pub fn of(u: &CanCore) -> CoreOutputs {
        let (t, f, s) = (&u.transmit, &u.rx_frame, &u.status);
        CoreOutputs {
            tx: u.tx.val(),
            rx_valid: u.rx_valid.val(),
            tx_addr: t.addr.val().to_u8(),
            tx_done: t.done.val(),
            tx_success: t.success.val(),
            rx_header: f.header.val(),
            rx_id: f.id.val().to_u32(),
            rx_ide: f.ide.val(),
            rx_rtr: f.rtr.val(),
            rx_dlc: f.dlc.val().to_u8(),
            rx_strobe: f.strobe.val(),
            rx_data: f.data.val().to_u8(),
            rx_index: f.index.val().to_u8(),
            bus_error: s.bus_error.val(),
            ecc: s.ecc.val().to_u8(),
            arbitration_lost: s.arbitration_lost.val(),
            alc: s.alc.val().to_u8(),
            tec: s.tec.val().to_u8(),
            rec: s.rec.val().to_u8(),
            error_passive: s.error_passive.val(),
            bus_off: s.bus_off.val(),
            transmitting: s.transmitting.val(),
            receiving: s.receiving.val(),
            state: s.state.val(),
            sample_point: u.sample_point.val(),
            segment: u.segment.val() as u8,
        }
    }
}
