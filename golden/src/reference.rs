//! Bit-level golden reference model of the classic CAN protocol (Bosch CAN 2.0A/2.0B,
//! ISO 11898-1) for several nodes on one wired-AND bus, written from the CAN rules and the
//! project's conformance catalog (`CONFORMANCE.md`), independently of the RTL.
//!
//! It is the oracle of the fault-injection property tests: one node sends one frame, at most one
//! [`Fault`] changes the level that one node (or every node) sees in one or more consecutive bits,
//! or keeps one node's drive off the bus for a while (a node cut from the bus), and [`simulate`]
//! computes bit by bit what every node drives, what the bus carries, and for every node the
//! frames it delivers, the errors it detects and its final error counters.
//!
//! The model works in whole bit times. In every bit each node first decides the level it drives
//! from its state, the bus is the AND of all drives (`true` = recessive), each node sees the bus
//! level (changed by the fault at the fault's bit) and then processes the bit it saw.
//!
//! Conventions (those of the catalog, plus the choices listed here):
//! * an error detected at bit `e` is recorded at `e`; its error flag starts at `e + 1`. A CRC
//!   error is detected at the ACK delimiter (flag from the first EOF bit); a dominant ACK
//!   delimiter is a form error instead. An ACK error is detected at the ACK slot.
//! * the error flag is active or passive according to the state before that error's counter
//!   change; REC saturates at 255; a receiver's REC is decremented (or set to 127 from above
//!   127) at the ACK slot when its dominant ACK was sent and seen; the transmitter's TEC is
//!   decremented after the last EOF bit; bus-off (TEC above 255) sets TEC = 127, REC = 0 and the
//!   node stays recessive for the rest of the run (no recovery: the host would have to act).
//! * a transmitter's bit error on its own stuff bit is a bit error; the exception is a recessive
//!   stuff bit read dominant in the arbitration field, a stuff error that leaves TEC unchanged
//!   (rule 3 exception b). A stuff bit belongs to the field of the bit after it (the project's
//!   ECC convention), and the arbitration field includes IDE in both formats (SJA1000 ALC
//!   position 12: a standard remote frame beats an extended frame there), so the stuff bit between
//!   RTR and IDE of a standard frame is in the arbitration field, the one after an extended RTR is
//!   not.
//! * the node that transmitted the last frame stays "transmitter" for the fault confinement
//!   rules until the next start of frame (error and overload frames after its own frame); a
//!   transmitter that loses arbitration is a receiver from that bit on (no suspend after it).
//! * [`Outcome::bus`] is the AND of the drives that reach the bus: a fault changes what nodes see,
//!   not the bus, except [`FaultKind::Disconnected`], whose node's drive is left out.
//!   [`NodeResult::drive`] (an addition to the requested API) gives what each node drove.
//! * the run ends [`IDLE_BITS_AT_END`] bus-idle bits after the last node's intermission.

use crate::crc15::crc15;
use crate::frame::{
    encode, EncodedFrame, Field, Frame, Id, DELIMITER_BITS, DOMINANT, FLAG_BITS, INTERMISSION_BITS,
    RECESSIVE, STUFF_RUN, SUSPEND_BITS,
};

/// Index (from 0) of the last EOF bit.
const LAST_EOF_INDEX: u8 = 6;
/// Index (from 0) of the EOF bit that is the receiver's validity point (EOF bit 6).
const VALIDITY_EOF_INDEX: u8 = 5;
/// Consecutive dominant bits after a flag that cost 8 more (rule 6: 14 including an active
/// flag, 8 after a passive flag).
const TOLERATED_DOMINANT_PERIOD: usize = 8;
/// Counter value from which a node is error passive.
const ERROR_PASSIVE_LIMIT: u16 = 128;
/// Largest TEC value; above it the node goes bus-off.
const MAX_TEC: u16 = 255;
/// REC saturates here (choice of the catalog, EC-15).
const MAX_REC: u16 = 255;
/// REC after a successful reception with REC above 127 (choice of the catalog, EC-13).
const REC_AFTER_PASSIVE_SUCCESS: u16 = 127;
/// TEC on entering bus-off (SJA1000).
const BUS_OFF_TEC: u16 = 127;
/// Counter increment of rules 2 to 6.
const PENALTY: u16 = 8;
/// Recessive bits every node must have spent in bus idle before the run ends.
pub const IDLE_BITS_AT_END: usize = 3;

// Destuffed bit positions, counted from the SOF (position 0).
/// First base identifier bit.
const BASE_ID_START: usize = 1;
/// Base identifier width.
const BASE_ID_BITS: usize = 11;
/// RTR of a standard frame, SRR of an extended frame.
const STANDARD_RTR: usize = 12;
/// Identifier extension bit.
const IDE: usize = 13;
/// First bit of identifier bits 17..0 of an extended frame.
const EXTENDED_ID_START: usize = 14;
/// Width of the identifier extension.
const EXTENDED_ID_BITS: usize = 18;
/// RTR of an extended frame.
const EXTENDED_RTR: usize = 32;
/// First DLC bit of a standard frame.
const STANDARD_DLC_START: usize = 15;
/// First DLC bit of an extended frame.
const EXTENDED_DLC_START: usize = 35;
/// DLC width.
const DLC_BITS: usize = 4;
/// CRC sequence width.
const CRC_BITS: usize = 15;
/// Largest number of data bytes.
const MAX_DATA_BYTES: usize = 8;

/// How a fault changes the level seen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaultKind {
    /// The level seen is the inverse of the bus level.
    Flip,
    /// The level seen is dominant whatever the bus carries.
    Dominant,
    /// The level seen is recessive whatever the bus carries (with a node and several bits: a node
    /// whose receiver is cut from the bus).
    Recessive,
    /// The node's drive does not reach the bus (its transmitter is cut off); it sees the bus the
    /// other nodes make. Needs a node.
    Disconnected,
}

impl FaultKind {
    /// The level seen when the bus carries `level`.
    fn apply(self, level: bool) -> bool {
        match self {
            FaultKind::Flip => !level,
            FaultKind::Dominant => DOMINANT,
            FaultKind::Recessive => RECESSIVE,
            FaultKind::Disconnected => level,
        }
    }
}

/// One fault: from bus bit `bit` (bit 0 = SOF of the first transmission attempt) for `bits` bits,
/// seen by node `node` only (a local disturbance) or by all nodes (`None`: the bus itself).
///
/// The fault changes only what the nodes see, never what they drive; the bus level recorded in
/// [`Outcome::bus`] is the AND of the drives that reach the bus (all but a
/// [`FaultKind::Disconnected`] node's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Fault {
    /// Bus bit index of the fault's first bit.
    pub bit: usize,
    /// Consecutive bits the fault lasts (at least 1).
    pub bits: usize,
    /// The node that sees the fault, or `None` for every node.
    pub node: Option<usize>,
    /// How the level seen is changed.
    pub kind: FaultKind,
}

impl Fault {
    /// A fault of the one bus bit `bit`.
    pub fn single(bit: usize, node: Option<usize>, kind: FaultKind) -> Fault {
        Fault {
            bit,
            bits: 1,
            node,
            kind,
        }
    }

    /// Whether the fault lasts through bus bit `bit`.
    fn covers(&self, bit: usize) -> bool {
        (self.bit..self.bit + self.bits).contains(&bit)
    }

    /// The level node `node` sees in bus bit `bit` when the bus carries `level`.
    fn seen(&self, bit: usize, node: usize, level: bool) -> bool {
        let hits_node = self.node.is_none_or(|faulty| faulty == node);
        if self.covers(bit) && hits_node {
            self.kind.apply(level)
        } else {
            level
        }
    }

    /// Whether what node `node` drives in bus bit `bit` reaches the bus.
    fn reaches_bus(&self, bit: usize, node: usize) -> bool {
        !(self.kind == FaultKind::Disconnected && self.node == Some(node) && self.covers(bit))
    }
}

/// The run to simulate: `nodes` nodes, node `transmitter` sends `frame`; `tec` and `rec` are the
/// initial error counters, one per node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Scenario {
    /// Number of nodes on the bus (at least 1).
    pub nodes: usize,
    /// Index of the node that sends `frame` from bit 0.
    pub transmitter: usize,
    /// The frame to send.
    pub frame: Frame,
    /// Initial transmit error counter of each node.
    pub tec: Vec<u8>,
    /// Initial receive error counter of each node.
    pub rec: Vec<u8>,
}

/// The kind of an error a node detects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Detected {
    /// Bit error: the node saw another level than it sent (outside the exceptions).
    Bit,
    /// Stuff error: six equal bits in the stuffed region.
    Stuff,
    /// CRC error (detected at the ACK delimiter).
    Crc,
    /// Form error: a dominant fixed-form bit (CRC delimiter, ACK delimiter, EOF, error or
    /// overload delimiter bits 2..7).
    Form,
    /// ACK error: the transmitter saw the ACK slot recessive.
    Ack,
}

/// What happened to one node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeResult {
    /// Delivered frames: (bus bit index of the validity point, EOF bit 6; frame).
    pub received: Vec<(usize, Frame)>,
    /// Detected errors: (bus bit index where detected, kind); the flag starts at the next bit.
    pub errors: Vec<(usize, Detected)>,
    /// Final transmit error counter.
    pub tec: u8,
    /// Final receive error counter.
    pub rec: u8,
    /// `true` when the node ends error passive (a counter at 128 or more, not bus-off).
    pub error_passive: bool,
    /// `true` when the node went bus-off.
    pub bus_off: bool,
    /// The level the node drove in every bit (`true` = recessive), as long as [`Outcome::bus`].
    pub drive: Vec<bool>,
}

/// The result of [`simulate`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outcome {
    /// Bus level of every bit from bit 0 (`true` = recessive).
    pub bus: Vec<bool>,
    /// One result per node.
    pub nodes: Vec<NodeResult>,
    /// `true` when the transmitter's request ended with success.
    pub transmitted: bool,
    /// Transmission attempts started by the transmitter (SOF sent, or first identifier bit
    /// after a foreign SOF in intermission bit 3).
    pub attempts: usize,
}

/// Simulates `scenario` with at most one `fault`, bit by bit, until the transmitter has succeeded
/// (or is bus-off) and every node that is not bus-off has seen [`IDLE_BITS_AT_END`] recessive
/// bits in bus idle, or until `max_bits` bits.
///
/// # Panics
/// If the scenario is inconsistent: no node, `transmitter >= nodes`, or counter vectors whose
/// length is not `nodes`; or if the fault lasts no bit or disconnects no particular node.
pub fn simulate(scenario: &Scenario, fault: Option<&Fault>, max_bits: usize) -> Outcome {
    check_scenario(scenario, fault);
    let mut nodes: Vec<Node> = (0..scenario.nodes)
        .map(|index| Node::new(scenario, index))
        .collect();
    let mut bus = Vec::new();
    while bus.len() < max_bits {
        let bit = bus.len();
        let level = nodes.iter().enumerate().all(|(index, node)| {
            node.drive() || fault.is_some_and(|fault| !fault.reaches_bus(bit, index))
        });
        bus.push(level);
        for (index, node) in nodes.iter_mut().enumerate() {
            let seen = fault.map_or(level, |fault| fault.seen(bit, index, level));
            node.step(bit, seen);
        }
        if run_is_over(&nodes, scenario.transmitter) {
            break;
        }
    }
    let transmitter = &nodes[scenario.transmitter];
    Outcome {
        bus,
        transmitted: transmitter.transmitted,
        attempts: transmitter.attempts,
        nodes: nodes.into_iter().map(Node::into_result).collect(),
    }
}

/// Panics on an inconsistent scenario or fault.
fn check_scenario(scenario: &Scenario, fault: Option<&Fault>) {
    if let Some(fault) = fault {
        assert!(fault.bits > 0, "a fault lasts at least one bit");
        assert!(
            fault.kind != FaultKind::Disconnected || fault.node.is_some(),
            "a disconnection is of one node"
        );
    }
    assert!(scenario.nodes > 0, "a scenario needs at least one node");
    assert!(
        scenario.transmitter < scenario.nodes,
        "transmitter {} is not one of the {} nodes",
        scenario.transmitter,
        scenario.nodes
    );
    assert_eq!(scenario.tec.len(), scenario.nodes, "one TEC per node");
    assert_eq!(scenario.rec.len(), scenario.nodes, "one REC per node");
}

/// `true` once the transmitter's request has ended and every node rests in bus idle (or is
/// bus-off).
fn run_is_over(nodes: &[Node], transmitter: usize) -> bool {
    nodes[transmitter].request.is_none() && nodes.iter().all(Node::is_quiet)
}

/// The node's part in the current (or last) frame, which selects the fault confinement rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Transmitter,
    Receiver,
}

/// How an error changes the error counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Penalty {
    /// Rule 1 (receiver +1) or rule 3 (transmitter +8).
    Normal,
    /// Rules 4 and 5: bit error while sending an active error flag or an overload flag: +8.
    OwnFlagBitError,
    /// Rule 3 exception b: stuff error on a recessive stuff bit of the arbitration field.
    Exempt,
}

/// The protocol state of a node; what it drives follows from it.
#[derive(Clone, Debug, PartialEq, Eq)]
enum State {
    /// Bus idle; counts the recessive bits seen.
    Idle { recessive_bits: usize },
    /// Sending its frame; `position` is the wire bit (from SOF) sent in the current bit. The
    /// decoder follows the bus in the stuffed region, for the case of a lost arbitration.
    Transmitting { position: usize, decoder: Decoder },
    /// Receiving a frame.
    Receiving { decoder: Decoder },
    /// Sending an active error flag; `sent` flag bits done.
    ActiveErrorFlag { sent: u8 },
    /// Sending a passive error flag: waits for 6 equal bits; `ack_exception` while a passive
    /// transmitter's ACK error is still free (rule 3 exception a).
    PassiveErrorFlag {
        level: bool,
        equal_bits: u8,
        ack_exception: bool,
    },
    /// Sending an overload flag; `sent` flag bits done.
    OverloadFlag { sent: u8 },
    /// Flag done, waiting for the first recessive bit (the first delimiter bit).
    AfterFlag {
        error_flag: bool,
        dominant_bits: usize,
    },
    /// Error or overload delimiter; `recessive_bits` delimiter bits seen so far (1..=7).
    Delimiter { recessive_bits: u8 },
    /// Intermission; `bits` intermission bits seen so far.
    Intermission { bits: u8 },
    /// Suspend transmission of an error-passive transmitter; `bits` seen so far.
    Suspend { bits: u8 },
    /// Bus-off: recessive, deaf.
    BusOff,
}

/// The pending transmission request.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Request {
    encoded: EncodedFrame,
}

/// What a transmitter makes of one bit it sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum TxCheck {
    /// The bit went out as it should.
    Sent,
    /// Recessive identifier/SRR/IDE/RTR bit read dominant: now a receiver.
    ArbitrationLost,
    /// An error, with its counter rule.
    Error(Detected, Penalty),
}

impl Request {
    fn new(frame: &Frame) -> Request {
        Request {
            encoded: encode(frame),
        }
    }

    /// Bit monitoring, ACK check and form check of wire bit `position` seen as `seen`.
    fn check(&self, position: usize, seen: bool) -> TxCheck {
        let sent = self.encoded.bits[position];
        let tag = self.encoded.tags[position];
        if tag.field == Field::AckSlot {
            return match seen {
                DOMINANT => TxCheck::Sent,
                RECESSIVE => TxCheck::Error(Detected::Ack, Penalty::Normal),
            };
        }
        if seen == sent {
            return TxCheck::Sent;
        }
        if sent == RECESSIVE && self.in_arbitration(position) {
            return if tag.stuff {
                TxCheck::Error(Detected::Stuff, Penalty::Exempt)
            } else {
                TxCheck::ArbitrationLost
            };
        }
        if is_fixed_form(tag.field) {
            TxCheck::Error(Detected::Form, Penalty::Normal)
        } else {
            TxCheck::Error(Detected::Bit, Penalty::Normal)
        }
    }

    /// `true` when wire bit `position` is in the arbitration field (ID, SRR, IDE, RTR: the SJA1000
    /// ALC positions); a stuff bit belongs to the field of the bit after it.
    fn in_arbitration(&self, position: usize) -> bool {
        let tags = &self.encoded.tags;
        let field = if tags[position].stuff {
            tags[position + 1].field
        } else {
            tags[position].field
        };
        matches!(
            field,
            Field::BaseId | Field::Srr | Field::Ide | Field::ExtId | Field::Rtr
        )
    }
}

/// `true` for the fixed-form fields of a data or remote frame after the CRC.
fn is_fixed_form(field: Field) -> bool {
    matches!(field, Field::CrcDelim | Field::AckDelim | Field::Eof)
}

/// One simulated node: protocol state, fault confinement and what it reports.
#[derive(Clone, Debug)]
struct Node {
    tec: u16,
    rec: u16,
    bus_off: bool,
    role: Role,
    request: Option<Request>,
    state: State,
    attempts: usize,
    transmitted: bool,
    received: Vec<(usize, Frame)>,
    errors: Vec<(usize, Detected)>,
    drive: Vec<bool>,
}

impl Node {
    /// Node `index` of `scenario`, integrated and idle; the transmitter starts its SOF at bit 0.
    fn new(scenario: &Scenario, index: usize) -> Node {
        let mut node = Node {
            tec: u16::from(scenario.tec[index]),
            rec: u16::from(scenario.rec[index]),
            bus_off: false,
            role: Role::Receiver,
            request: None,
            state: State::Idle { recessive_bits: 0 },
            attempts: 0,
            transmitted: false,
            received: Vec::new(),
            errors: Vec::new(),
            drive: Vec::new(),
        };
        if index == scenario.transmitter {
            node.request = Some(Request::new(&scenario.frame));
            node.state = node.start_transmission();
        }
        node
    }

    /// The level the node drives in the current bit.
    fn drive(&self) -> bool {
        match &self.state {
            State::Transmitting { position, .. } => {
                let request = self.request.as_ref().expect("a transmitter has a request");
                request.encoded.bits[*position]
            }
            State::Receiving { decoder } => decoder.drive(),
            State::ActiveErrorFlag { .. } | State::OverloadFlag { .. } => DOMINANT,
            _ => RECESSIVE,
        }
    }

    /// `true` in bus idle for at least [`IDLE_BITS_AT_END`] bits, or bus-off.
    fn is_quiet(&self) -> bool {
        match self.state {
            State::Idle { recessive_bits } => recessive_bits >= IDLE_BITS_AT_END,
            State::BusOff => true,
            _ => false,
        }
    }

    /// `true` while error passive (a counter at 128 or more).
    fn error_passive(&self) -> bool {
        !self.bus_off && (self.tec >= ERROR_PASSIVE_LIMIT || self.rec >= ERROR_PASSIVE_LIMIT)
    }

    /// Records the drive of bit `bit` and processes the level `seen` in it.
    fn step(&mut self, bit: usize, seen: bool) {
        self.drive.push(self.drive());
        let state = std::mem::replace(&mut self.state, State::BusOff);
        self.state = match state {
            State::Idle { recessive_bits } => self.idle(seen, recessive_bits),
            State::Transmitting { position, decoder } => {
                self.transmitting(bit, seen, position, decoder)
            }
            State::Receiving { decoder } => self.receiving(bit, seen, decoder),
            State::ActiveErrorFlag { sent } => self.dominant_flag(bit, seen, sent, false),
            State::OverloadFlag { sent } => self.dominant_flag(bit, seen, sent, true),
            State::PassiveErrorFlag {
                level,
                equal_bits,
                ack_exception,
            } => self.passive_flag(seen, level, equal_bits, ack_exception),
            State::AfterFlag {
                error_flag,
                dominant_bits,
            } => self.after_flag(seen, error_flag, dominant_bits),
            State::Delimiter { recessive_bits } => self.delimiter(bit, seen, recessive_bits),
            State::Intermission { bits } => self.intermission(seen, bits),
            State::Suspend { bits } => self.suspend(seen, bits),
            State::BusOff => State::BusOff,
        };
    }

    // ---- frames --------------------------------------------------------------------------

    /// Bus idle: a dominant bit is a SOF.
    fn idle(&mut self, seen: bool, recessive_bits: usize) -> State {
        match seen {
            DOMINANT => {
                let transmit = self.may_transmit_now();
                self.start_on_sof(transmit)
            }
            RECESSIVE => State::Idle {
                recessive_bits: recessive_bits + 1,
            },
        }
    }

    /// Starts an attempt with the SOF in the next bit.
    fn start_transmission(&mut self) -> State {
        self.attempts += 1;
        self.role = Role::Transmitter;
        State::Transmitting {
            position: 0,
            decoder: Decoder::new(),
        }
    }

    /// A SOF was seen (idle, intermission bit 3 or suspend): a node allowed to `transmit` sends
    /// its first identifier bit next (no SOF of its own), any other node receives.
    fn start_on_sof(&mut self, transmit: bool) -> State {
        let mut decoder = Decoder::new();
        let event = decoder.process(DOMINANT);
        assert_eq!(event, RxEvent::None, "a SOF starts a frame");
        if transmit {
            self.attempts += 1;
            self.role = Role::Transmitter;
            State::Transmitting {
                position: 1,
                decoder,
            }
        } else {
            self.role = Role::Receiver;
            State::Receiving { decoder }
        }
    }

    /// Transmitter: bit monitoring of wire bit `position`, success after the last EOF bit.
    fn transmitting(
        &mut self,
        bit: usize,
        seen: bool,
        position: usize,
        mut decoder: Decoder,
    ) -> State {
        let request = self.request.as_ref().expect("a transmitter has a request");
        let frame_bits = request.encoded.len();
        match request.check(position, seen) {
            TxCheck::Sent => {
                if decoder.in_stuffed_region() {
                    let event = decoder.process(seen);
                    assert_eq!(event, RxEvent::None, "own bits decode without error");
                }
                if position + 1 == frame_bits {
                    self.succeed()
                } else {
                    State::Transmitting {
                        position: position + 1,
                        decoder,
                    }
                }
            }
            TxCheck::ArbitrationLost => {
                self.role = Role::Receiver;
                self.receiving(bit, seen, decoder)
            }
            TxCheck::Error(kind, penalty) => self.signal_error(bit, kind, penalty),
        }
    }

    /// The frame went out: rule 7, the request ends, intermission follows.
    fn succeed(&mut self) -> State {
        self.transmitted = true;
        self.request = None;
        self.tec = self.tec.saturating_sub(1);
        State::Intermission { bits: 0 }
    }

    /// Receiver: destuffing, CRC, form and ACK checks, delivery at the validity point.
    fn receiving(&mut self, bit: usize, seen: bool, mut decoder: Decoder) -> State {
        match decoder.process(seen) {
            RxEvent::None => State::Receiving { decoder },
            RxEvent::AckSent => {
                self.successful_reception();
                State::Receiving { decoder }
            }
            RxEvent::Valid(frame) => {
                self.received.push((bit, frame));
                State::Receiving { decoder }
            }
            RxEvent::Error(kind) => self.signal_error(bit, kind, Penalty::Normal),
            RxEvent::Overload => State::OverloadFlag { sent: 0 },
            RxEvent::End => State::Intermission { bits: 0 },
        }
    }

    // ---- error and overload frames ---------------------------------------------------------

    /// Records an error at `bit`, applies its counter change and starts the error flag (active
    /// or passive according to the state before the change).
    fn signal_error(&mut self, bit: usize, kind: Detected, penalty: Penalty) -> State {
        self.errors.push((bit, kind));
        let passive = self.error_passive();
        let ack_exception = passive && kind == Detected::Ack && self.role == Role::Transmitter;
        if !ack_exception {
            self.apply_penalty(penalty);
        }
        if self.bus_off {
            State::BusOff
        } else if passive {
            State::PassiveErrorFlag {
                level: RECESSIVE,
                equal_bits: 0,
                ack_exception,
            }
        } else {
            State::ActiveErrorFlag { sent: 0 }
        }
    }

    /// Active error flag or overload flag: 6 dominant bits; a recessive bit seen is a bit error.
    fn dominant_flag(&mut self, bit: usize, seen: bool, sent: u8, overload: bool) -> State {
        if seen == RECESSIVE {
            return self.signal_error(bit, Detected::Bit, Penalty::OwnFlagBitError);
        }
        let sent = sent + 1;
        match (sent < FLAG_BITS, overload) {
            (true, true) => State::OverloadFlag { sent },
            (true, false) => State::ActiveErrorFlag { sent },
            (false, _) => State::AfterFlag {
                error_flag: !overload,
                dominant_bits: 0,
            },
        }
    }

    /// Passive error flag: complete after 6 equal bits seen. A dominant bit ends the ACK error
    /// exemption of a passive transmitter (+8 then).
    fn passive_flag(
        &mut self,
        seen: bool,
        level: bool,
        equal_bits: u8,
        ack_exception: bool,
    ) -> State {
        let mut ack_exception = ack_exception;
        if ack_exception && seen == DOMINANT {
            ack_exception = false;
            self.raise_tec(PENALTY);
            if self.bus_off {
                return State::BusOff;
            }
        }
        let equal_bits = if equal_bits > 0 && seen == level {
            equal_bits + 1
        } else {
            1
        };
        if equal_bits == FLAG_BITS {
            State::AfterFlag {
                error_flag: true,
                dominant_bits: 0,
            }
        } else {
            State::PassiveErrorFlag {
                level: seen,
                equal_bits,
                ack_exception,
            }
        }
    }

    /// After a flag: dominant bits are tolerated (rules 2 and 6 apply) until the first recessive
    /// bit, which is delimiter bit 1.
    fn after_flag(&mut self, seen: bool, error_flag: bool, dominant_bits: usize) -> State {
        if seen == RECESSIVE {
            return State::Delimiter { recessive_bits: 1 };
        }
        let dominant_bits = dominant_bits + 1;
        if dominant_bits == 1 && error_flag && self.role == Role::Receiver {
            self.raise_rec(PENALTY); // rule 2
        }
        if dominant_bits.is_multiple_of(TOLERATED_DOMINANT_PERIOD) {
            self.raise_own_counter(PENALTY); // rule 6
        }
        if self.bus_off {
            State::BusOff
        } else {
            State::AfterFlag {
                error_flag,
                dominant_bits,
            }
        }
    }

    /// Error or overload delimiter bits 2..8: dominant in 2..7 is a form error, dominant in 8 an
    /// overload condition.
    fn delimiter(&mut self, bit: usize, seen: bool, recessive_bits: u8) -> State {
        let number = recessive_bits + 1;
        match (seen, number == DELIMITER_BITS) {
            (DOMINANT, true) => State::OverloadFlag { sent: 0 },
            (DOMINANT, false) => self.signal_error(bit, Detected::Form, Penalty::Normal),
            (RECESSIVE, true) => State::Intermission { bits: 0 },
            (RECESSIVE, false) => State::Delimiter {
                recessive_bits: number,
            },
        }
    }

    // ---- interframe space -------------------------------------------------------------------

    /// Intermission: dominant in bit 1 or 2 is an overload condition, in bit 3 a SOF.
    fn intermission(&mut self, seen: bool, bits: u8) -> State {
        let number = bits + 1;
        match (seen, number == INTERMISSION_BITS) {
            (DOMINANT, false) => State::OverloadFlag { sent: 0 },
            (DOMINANT, true) => {
                let transmit = self.may_transmit_now();
                self.start_on_sof(transmit)
            }
            (RECESSIVE, false) => State::Intermission { bits: number },
            (RECESSIVE, true) => self.after_intermission(),
        }
    }

    /// End of intermission: transmit, suspend, or bus idle.
    fn after_intermission(&mut self) -> State {
        if self.request.is_none() {
            State::Idle { recessive_bits: 0 }
        } else if self.must_suspend() {
            State::Suspend { bits: 0 }
        } else {
            self.start_transmission()
        }
    }

    /// Suspend transmission: a dominant bit is another node's SOF (received).
    fn suspend(&mut self, seen: bool, bits: u8) -> State {
        let number = bits + 1;
        match (seen, number == SUSPEND_BITS) {
            (DOMINANT, _) => self.start_on_sof(false),
            (RECESSIVE, false) => State::Suspend { bits: number },
            (RECESSIVE, true) => self.start_transmission(),
        }
    }

    /// An error-passive node that was transmitter of the last frame suspends before retrying.
    fn must_suspend(&self) -> bool {
        self.role == Role::Transmitter && self.error_passive()
    }

    /// `true` when a pending request may start at once (on a foreign SOF: without SOF).
    fn may_transmit_now(&self) -> bool {
        self.request.is_some() && !self.must_suspend()
    }

    // ---- fault confinement ---------------------------------------------------------------------

    /// Counter change of an error according to the node's role.
    fn apply_penalty(&mut self, penalty: Penalty) {
        match (penalty, self.role) {
            (Penalty::Exempt, _) => {}
            (Penalty::Normal | Penalty::OwnFlagBitError, Role::Transmitter) => {
                self.raise_tec(PENALTY)
            }
            (Penalty::OwnFlagBitError, Role::Receiver) => self.raise_rec(PENALTY),
            (Penalty::Normal, Role::Receiver) => self.raise_rec(1),
        }
    }

    /// Rule 6: +8 on TEC for a transmitter, on REC for a receiver.
    fn raise_own_counter(&mut self, amount: u16) {
        match self.role {
            Role::Transmitter => self.raise_tec(amount),
            Role::Receiver => self.raise_rec(amount),
        }
    }

    /// TEC increase; above 255 the node goes bus-off (TEC 127, REC 0, request dropped).
    fn raise_tec(&mut self, amount: u16) {
        self.tec += amount;
        if self.tec > MAX_TEC {
            self.bus_off = true;
            self.tec = BUS_OFF_TEC;
            self.rec = 0;
            self.request = None;
        }
    }

    /// REC increase, saturating at 255.
    fn raise_rec(&mut self, amount: u16) {
        self.rec = (self.rec + amount).min(MAX_REC);
    }

    /// Rule 8, when the receiver's ACK went out: REC − 1, or 127 from above 127.
    fn successful_reception(&mut self) {
        if self.rec > REC_AFTER_PASSIVE_SUCCESS {
            self.rec = REC_AFTER_PASSIVE_SUCCESS;
        } else {
            self.rec = self.rec.saturating_sub(1);
        }
    }

    /// The node's part of the [`Outcome`].
    fn into_result(self) -> NodeResult {
        let error_passive = self.error_passive();
        NodeResult {
            received: self.received,
            errors: self.errors,
            tec: u8::try_from(self.tec).expect("TEC stays within 0..=255"),
            rec: u8::try_from(self.rec).expect("REC saturates at 255"),
            error_passive,
            bus_off: self.bus_off,
            drive: self.drive,
        }
    }
}

/// Where a receiver is in a data or remote frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// SOF to the last CRC bit (and its stuff bit): destuffed.
    Stuffed,
    CrcDelimiter,
    AckSlot,
    AckDelimiter,
    /// EOF bit index 0..=6.
    Eof(u8),
}

/// What a receiver makes of one bit.
#[derive(Clone, Debug, PartialEq, Eq)]
enum RxEvent {
    None,
    Error(Detected),
    /// The receiver's dominant ACK went out (rule 8).
    AckSent,
    /// Validity point: the frame is delivered.
    Valid(Frame),
    /// Dominant last EOF bit: overload condition.
    Overload,
    /// Last EOF bit recessive: intermission follows.
    End,
}

/// Receiver side of a frame, fed with the bits seen from the SOF on: destuffing, stuff check,
/// CRC, fixed-form checks, ACK.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Decoder {
    /// Destuffed bits from the SOF.
    bits: Vec<bool>,
    /// Level of the current run of equal wire bits.
    run_level: bool,
    /// Length of the current run (0 before the SOF).
    run_len: u8,
    stage: Stage,
    /// The received CRC matches (known from the end of the stuffed region).
    crc_ok: bool,
}

impl Decoder {
    fn new() -> Decoder {
        Decoder {
            bits: Vec::with_capacity(EXTENDED_DLC_START + DLC_BITS + 64 + CRC_BITS),
            run_level: RECESSIVE,
            run_len: 0,
            stage: Stage::Stuffed,
            crc_ok: false,
        }
    }

    /// A receiver sends a dominant ACK iff the CRC was right.
    fn drive(&self) -> bool {
        if self.stage == Stage::AckSlot && self.crc_ok {
            DOMINANT
        } else {
            RECESSIVE
        }
    }

    fn in_stuffed_region(&self) -> bool {
        self.stage == Stage::Stuffed
    }

    /// Processes one wire bit seen.
    fn process(&mut self, seen: bool) -> RxEvent {
        match self.stage {
            Stage::Stuffed => self.stuffed_bit(seen),
            Stage::CrcDelimiter => {
                self.stage = Stage::AckSlot;
                form_check(seen)
            }
            Stage::AckSlot => {
                self.stage = Stage::AckDelimiter;
                self.ack_slot(seen)
            }
            Stage::AckDelimiter => {
                self.stage = Stage::Eof(0);
                self.ack_delimiter(seen)
            }
            Stage::Eof(index) => self.eof_bit(index, seen),
        }
    }

    /// A bit of the stuffed region: stuff bit (checked and dropped) or frame bit.
    fn stuffed_bit(&mut self, seen: bool) -> RxEvent {
        if self.run_len == STUFF_RUN {
            if seen == self.run_level {
                return RxEvent::Error(Detected::Stuff);
            }
            self.run_level = seen;
            self.run_len = 1;
        } else {
            if self.run_len > 0 && seen == self.run_level {
                self.run_len += 1;
            } else {
                self.run_level = seen;
                self.run_len = 1;
            }
            self.bits.push(seen);
        }
        let stuff_bit_follows = self.run_len == STUFF_RUN;
        if !stuff_bit_follows && Some(self.bits.len()) == stuffed_length(&self.bits) {
            // The CRC register over the data and the received CRC ends at 0 iff they match.
            self.crc_ok = crc15(self.bits.iter().copied()) == 0;
            self.stage = Stage::CrcDelimiter;
        }
        RxEvent::None
    }

    /// ACK slot: a receiver with a right CRC sent dominant; seeing recessive is a bit error.
    fn ack_slot(&self, seen: bool) -> RxEvent {
        match (self.crc_ok, seen) {
            (false, _) => RxEvent::None,
            (true, DOMINANT) => RxEvent::AckSent,
            (true, RECESSIVE) => RxEvent::Error(Detected::Bit),
        }
    }

    /// ACK delimiter: form check first, then the CRC error (flag from the next bit).
    fn ack_delimiter(&self, seen: bool) -> RxEvent {
        match (seen, self.crc_ok) {
            (DOMINANT, _) => RxEvent::Error(Detected::Form),
            (RECESSIVE, false) => RxEvent::Error(Detected::Crc),
            (RECESSIVE, true) => RxEvent::None,
        }
    }

    /// EOF: bits 1..6 must be recessive, the frame is valid after bit 6; a dominant bit 7 is
    /// an overload condition.
    fn eof_bit(&mut self, index: u8, seen: bool) -> RxEvent {
        if index == LAST_EOF_INDEX {
            return match seen {
                DOMINANT => RxEvent::Overload,
                RECESSIVE => RxEvent::End,
            };
        }
        if seen == DOMINANT {
            return RxEvent::Error(Detected::Form);
        }
        self.stage = Stage::Eof(index + 1);
        if index == VALIDITY_EOF_INDEX {
            RxEvent::Valid(self.frame())
        } else {
            RxEvent::None
        }
    }

    /// The frame in the destuffed bits (complete through the CRC).
    fn frame(&self) -> Frame {
        let bits = &self.bits;
        let base = value(&bits[BASE_ID_START..BASE_ID_START + BASE_ID_BITS]);
        let extended = bits[IDE] == RECESSIVE;
        let (id, remote, dlc_start) = if extended {
            let low = value(&bits[EXTENDED_ID_START..EXTENDED_ID_START + EXTENDED_ID_BITS]);
            let id = Id::Extended(base << EXTENDED_ID_BITS | low);
            (id, bits[EXTENDED_RTR] == RECESSIVE, EXTENDED_DLC_START)
        } else {
            let id = Id::Standard(u16::try_from(base).expect("11-bit identifier"));
            (id, bits[STANDARD_RTR] == RECESSIVE, STANDARD_DLC_START)
        };
        let dlc = u8::try_from(value(&bits[dlc_start..dlc_start + DLC_BITS])).expect("4 bits");
        let frame = if remote {
            Frame::remote(id, dlc)
        } else {
            let data_start = dlc_start + DLC_BITS;
            let data: Vec<u8> = bits[data_start..]
                .chunks(8)
                .take(data_bytes(dlc))
                .map(|byte| u8::try_from(value(byte)).expect("8 bits"))
                .collect();
            Frame::data_with_dlc(id, dlc, &data)
        };
        frame.expect("decoded fields are always in range")
    }
}

/// Form check of a fixed recessive bit.
fn form_check(seen: bool) -> RxEvent {
    match seen {
        DOMINANT => RxEvent::Error(Detected::Form),
        RECESSIVE => RxEvent::None,
    }
}

/// Data bytes of a data frame with this DLC.
fn data_bytes(dlc: u8) -> usize {
    usize::from(dlc).min(MAX_DATA_BYTES)
}

/// Number of destuffed bits from the SOF to the last CRC bit, once the received bits tell it
/// (after the DLC).
fn stuffed_length(bits: &[bool]) -> Option<usize> {
    let extended = *bits.get(IDE)? == RECESSIVE;
    let (rtr, dlc_start) = if extended {
        (EXTENDED_RTR, EXTENDED_DLC_START)
    } else {
        (STANDARD_RTR, STANDARD_DLC_START)
    };
    let dlc_end = dlc_start + DLC_BITS;
    let dlc = u8::try_from(value(bits.get(dlc_start..dlc_end)?)).expect("4 bits");
    let data = if bits[rtr] == RECESSIVE {
        0
    } else {
        8 * data_bytes(dlc)
    };
    Some(dlc_end + data + CRC_BITS)
}

/// The unsigned value of bits given MSB first (`true` = 1).
fn value(bits: &[bool]) -> u32 {
    bits.iter().fold(0, |acc, &bit| acc << 1 | u32::from(bit))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Enough for every scenario below to end on its own.
    const MAX_BITS: usize = 2000;

    /// Standard 0x123, one data byte 0x00: 55 wire bits; stuff bits at 17 (DLC), 25 (data) and
    /// 36 (CRC); CRC bits 29..=44, CRC delimiter 45, ACK slot 46, ACK delimiter 47, EOF 48..=54.
    fn frame_a() -> Frame {
        Frame::data(Id::Standard(0x123), &[0x00]).unwrap()
    }

    const A_DATA_STUFF: usize = 25;
    const A_CRC_BIT_10: usize = 40;
    const A_CRC_DELIM: usize = 45;
    const A_ACK_SLOT: usize = 46;
    const A_ACK_DELIM: usize = 47;
    const A_EOF: usize = 48;
    const A_VALIDITY: usize = 53;
    const A_LAST_EOF: usize = 54;
    const A_LEN: usize = 55;

    #[test]
    fn frame_a_layout_is_as_documented() {
        let encoded = encode(&frame_a());
        assert_eq!(encoded.len(), A_LEN);
        let stuff: Vec<usize> = (0..A_LEN).filter(|&i| encoded.tags[i].stuff).collect();
        assert_eq!(stuff, vec![17, A_DATA_STUFF, 36]);
        assert_eq!(encoded.tags[A_DATA_STUFF + 1].field, Field::Data);
        assert_eq!(encoded.position(Field::Crc, 10), Some(A_CRC_BIT_10));
        assert!(!encoded.bits[A_CRC_BIT_10], "CRC bit 10 is dominant");
        assert_eq!(encoded.position(Field::CrcDelim, 0), Some(A_CRC_DELIM));
        assert_eq!(encoded.position(Field::AckSlot, 0), Some(A_ACK_SLOT));
        assert_eq!(encoded.position(Field::AckDelim, 0), Some(A_ACK_DELIM));
        assert_eq!(encoded.position(Field::Eof, 0), Some(A_EOF));
        assert_eq!(encoded.position(Field::Eof, 5), Some(A_VALIDITY));
        assert_eq!(encoded.position(Field::Eof, 6), Some(A_LAST_EOF));
    }

    fn scenario(nodes: usize, frame: Frame, tec: u8, rec: u8) -> Scenario {
        Scenario {
            nodes,
            transmitter: 0,
            frame,
            tec: vec![tec; nodes],
            rec: vec![rec; nodes],
        }
    }

    fn fault(bit: usize, node: Option<usize>, kind: FaultKind) -> Fault {
        Fault::single(bit, node, kind)
    }

    fn run(scenario: &Scenario, fault: Option<Fault>) -> Outcome {
        simulate(scenario, fault.as_ref(), MAX_BITS)
    }

    /// The wire bits of `frame` with the ACK slot dominant (acknowledged).
    fn acked(frame: &Frame) -> Vec<bool> {
        let encoded = encode(frame);
        let ack = encoded.position(Field::AckSlot, 0).unwrap();
        let mut bits: Vec<bool> = encoded.bits.iter().by_vals().collect();
        bits[ack] = DOMINANT;
        bits
    }

    /// Builds an expected bus wave.
    #[derive(Default)]
    struct Wave(Vec<bool>);

    impl Wave {
        fn bits(mut self, bits: impl IntoIterator<Item = bool>) -> Wave {
            self.0.extend(bits);
            self
        }
        fn dominant(mut self, count: usize) -> Wave {
            self.0.extend(std::iter::repeat_n(DOMINANT, count));
            self
        }
        fn recessive(mut self, count: usize) -> Wave {
            self.0.extend(std::iter::repeat_n(RECESSIVE, count));
            self
        }
        /// The first `count` wire bits of `frame` as sent (ACK slot recessive).
        fn sent(self, frame: &Frame, count: usize) -> Wave {
            let bits: Vec<bool> = encode(frame).bits.iter().by_vals().take(count).collect();
            self.bits(bits)
        }
        /// A whole acknowledged frame, intermission and the idle bits that end the run.
        fn acked_frame_to_end(self, frame: &Frame) -> Wave {
            self.bits(acked(frame))
                .recessive(usize::from(INTERMISSION_BITS) + IDLE_BITS_AT_END)
        }
    }

    fn counters(outcome: &Outcome) -> Vec<(u8, u8)> {
        outcome.nodes.iter().map(|n| (n.tec, n.rec)).collect()
    }

    fn errors(outcome: &Outcome) -> Vec<Vec<(usize, Detected)>> {
        outcome.nodes.iter().map(|n| n.errors.clone()).collect()
    }

    fn received_at(outcome: &Outcome, node: usize) -> Vec<usize> {
        outcome.nodes[node].received.iter().map(|r| r.0).collect()
    }

    // ---- fault-free frames ---------------------------------------------------------------

    fn all_frames() -> Vec<Frame> {
        let mut frames = Vec::new();
        let ids = [
            Id::Standard(0x000),
            Id::Standard(0x7FF),
            Id::Standard(0x555),
            Id::Standard(0x2AA),
            Id::Extended(0),
            Id::Extended(0x1FFF_FFFF),
            Id::Extended(0x1555_5555),
            Id::Extended(0x0AAA_AAAA),
        ];
        let payload = [0x00, 0xFF, 0x0F, 0xF0, 0x1F, 0xE0, 0xA5, 0x3C];
        for id in ids {
            for dlc in 0..=15 {
                frames.push(Frame::remote(id, dlc).unwrap());
                let data = &payload[..data_bytes(dlc)];
                frames.push(Frame::data_with_dlc(id, dlc, data).unwrap());
            }
        }
        frames
    }

    #[test]
    fn fault_free_frames_give_the_golden_bits_and_one_delivery() {
        for frame in all_frames() {
            let scenario = Scenario {
                nodes: 4,
                transmitter: 2,
                frame,
                tec: vec![0, 7, 5, 130],
                rec: vec![3, 200, 0, 128],
            };
            let outcome = run(&scenario, None);
            let encoded = encode(&frame);
            let validity = encoded.position(Field::Eof, 5).unwrap();
            let ack = encoded.position(Field::AckSlot, 0).unwrap();
            assert_eq!(outcome.bus, Wave::default().acked_frame_to_end(&frame).0);
            assert!(outcome.transmitted, "{frame}");
            assert_eq!(outcome.attempts, 1);
            assert_eq!(
                counters(&outcome),
                vec![(0, 2), (7, 127), (4, 0), (130, 127)],
                "{frame}"
            );
            for (index, node) in outcome.nodes.iter().enumerate() {
                assert!(node.errors.is_empty(), "{frame}");
                assert!(!node.bus_off);
                let mut expected_drive = vec![RECESSIVE; outcome.bus.len()];
                if index == 2 {
                    assert!(node.received.is_empty());
                    for (i, bit) in encoded.bits.iter().by_vals().enumerate() {
                        expected_drive[i] = bit;
                    }
                } else {
                    assert_eq!(node.received, vec![(validity, frame)], "{frame}");
                    expected_drive[ack] = DOMINANT;
                }
                assert_eq!(node.drive, expected_drive, "{frame} node {index}");
            }
            // Node 3 keeps TEC 130: still error passive after its REC was set to 127.
            assert!(outcome.nodes[3].error_passive);
            assert!(!outcome.nodes[1].error_passive);
        }
    }

    // ---- bit errors and retransmission -----------------------------------------------------

    /// RT-01 / ST-05: the transmitter's data stuff bit is read inverted by every node: bit error
    /// for the transmitter, stuff error for the receivers, all at e; flag e+1..e+6, delimiter,
    /// intermission, retransmission at e+18; net TEC +7.
    #[test]
    fn rt_01_bit_error_retransmits_at_e_plus_18() {
        let frame = frame_a();
        let e = A_DATA_STUFF;
        let outcome = run(
            &scenario(3, frame, 9, 9),
            Some(fault(e, None, FaultKind::Flip)),
        );
        let expected = Wave::default()
            .sent(&frame, e + 1)
            .dominant(6)
            .recessive(8 + 3)
            .acked_frame_to_end(&frame);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(outcome.bus[e + 18], DOMINANT, "SOF at e+18");
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(e, Detected::Bit)],
                vec![(e, Detected::Stuff)],
                vec![(e, Detected::Stuff)]
            ]
        );
        assert_eq!(counters(&outcome), vec![(16, 9), (9, 9), (9, 9)]);
        assert!(outcome.transmitted);
        assert_eq!(outcome.attempts, 2);
        for node in 1..3 {
            assert_eq!(received_at(&outcome, node), vec![e + 18 + A_VALIDITY]);
        }
    }

    /// BE-01 on a bus with receivers: the transmitter alone reads its dominant ID bit 1
    /// recessive; the receivers see its flag as a sixth dominant bit (stuff error at 5), their
    /// flags end at 11, so everyone's delimiter starts at 12 and the retry is at 23.
    #[test]
    fn be_01_local_bit_error_and_the_receivers_stuff_error() {
        let frame = frame_a();
        let outcome = run(
            &scenario(3, frame, 0, 9),
            Some(fault(1, Some(0), FaultKind::Recessive)),
        );
        let expected = Wave::default()
            .sent(&frame, 2)
            .dominant(10) // tx flag 2..=7, receivers' flags 6..=11
            .recessive(8 + 3)
            .acked_frame_to_end(&frame);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(1, Detected::Bit)],
                vec![(5, Detected::Stuff)],
                vec![(5, Detected::Stuff)]
            ]
        );
        assert_eq!(counters(&outcome), vec![(7, 9), (0, 9), (0, 9)]);
        assert_eq!(received_at(&outcome, 1), vec![23 + A_VALIDITY]);
    }

    /// BE-02: SOF read recessive by every node: the receivers stay idle and take the
    /// transmitter's error flag for a SOF followed by 5 dominant bits (stuff error at 6).
    #[test]
    fn be_02_sof_read_recessive() {
        let frame = frame_a();
        let outcome = run(
            &scenario(2, frame, 0, 0),
            Some(fault(0, None, FaultKind::Recessive)),
        );
        let expected = Wave::default()
            .dominant(13) // SOF, tx flag 1..=6, receiver flag 7..=12
            .recessive(8 + 3)
            .acked_frame_to_end(&frame);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(
            errors(&outcome),
            vec![vec![(0, Detected::Bit)], vec![(6, Detected::Stuff)]]
        );
        assert_eq!(counters(&outcome), vec![(7, 0), (0, 0)]);
        assert_eq!(received_at(&outcome, 1), vec![24 + A_VALIDITY]);
    }

    // ---- stuff errors ------------------------------------------------------------------------

    /// ST-03 and rule 2: only receiver 1 reads the data stuff bit inverted (stuff error at 25).
    /// Its flag makes the transmitter see a bit error at its first recessive bit (29) and
    /// receiver 2 a stuff error at 31; their flags run to 37, so the first bit after receiver
    /// 1's flag (32) is dominant: REC +1 +8.
    #[test]
    fn st_03_stuff_error_at_one_receiver_and_rule_2() {
        let frame = frame_a();
        let outcome = run(
            &scenario(3, frame, 0, 0),
            Some(fault(A_DATA_STUFF, Some(1), FaultKind::Flip)),
        );
        let expected = Wave::default()
            .sent(&frame, A_DATA_STUFF + 1)
            .dominant(12) // 26..=37
            .recessive(8 + 3) // 38..=48
            .acked_frame_to_end(&frame); // retry at 49
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(29, Detected::Bit)],
                vec![(A_DATA_STUFF, Detected::Stuff)],
                vec![(31, Detected::Stuff)]
            ]
        );
        // Receiver 1: +1 +8 (rule 2) −1; receiver 2: +1 −1; transmitter +8 −1.
        assert_eq!(counters(&outcome), vec![(7, 0), (0, 8), (0, 0)]);
        assert_eq!(received_at(&outcome, 1), vec![49 + A_VALIDITY]);
        assert_eq!(received_at(&outcome, 2), vec![49 + A_VALIDITY]);
    }

    /// ST-06 / rule 3 exception b: a recessive stuff bit of the identifier read dominant is a
    /// stuff error for the transmitter (not an arbitration loss) and leaves TEC unchanged.
    #[test]
    fn st_06_recessive_stuff_bit_in_arbitration_read_dominant() {
        let frame = Frame::data(Id::Standard(0), &[]).unwrap();
        let encoded = encode(&frame);
        let stuff = 5;
        assert!(encoded.tags[stuff].stuff && encoded.bits[stuff]);
        assert_eq!(encoded.tags[stuff + 1].field, Field::BaseId);
        let outcome = run(
            &scenario(2, frame, 9, 9),
            Some(fault(stuff, None, FaultKind::Dominant)),
        );
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(stuff, Detected::Stuff)],
                vec![(stuff, Detected::Stuff)]
            ]
        );
        assert_eq!(counters(&outcome), vec![(8, 9), (9, 9)]);
        let validity = encoded.position(Field::Eof, 5).unwrap();
        assert_eq!(received_at(&outcome, 1), vec![stuff + 18 + validity]);
    }

    /// The stuff bit between RTR and IDE of a standard frame belongs to IDE (field of the next
    /// bit), an arbitration position: read dominant it is rule 3 exception b (stuff error, TEC
    /// unchanged, then -1 for the successful retry from 0 stays 0).
    #[test]
    fn stuff_bit_before_ide_is_in_arbitration() {
        let frame = Frame::data(Id::Standard(0x0F0), &[0x5A, 0xFF]).unwrap();
        let encoded = encode(&frame);
        let stuff = 13;
        assert!(encoded.tags[stuff].stuff && encoded.tags[stuff].field == Field::Rtr);
        let outcome = run(
            &scenario(2, frame, 0, 0),
            Some(fault(stuff, None, FaultKind::Dominant)),
        );
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(stuff, Detected::Stuff)],
                vec![(stuff, Detected::Stuff)]
            ]
        );
        assert_eq!(counters(&outcome), vec![(0, 0), (0, 0)]);
    }

    /// A recessive identifier bit read dominant by every node: the transmitter loses
    /// arbitration and receives; nobody drives any more, so all three see five recessive bits
    /// after the run of four dominant bits and detect a stuff error at bit 9. The former
    /// transmitter counts it as a receiver (REC +1) and retransmits.
    #[test]
    fn arbitration_lost_to_a_fault_then_retransmission() {
        let frame = frame_a();
        let encoded = encode(&frame);
        assert!(encoded.bits[3] && encoded.tags[3].field == Field::BaseId);
        let outcome = run(
            &scenario(3, frame, 0, 0),
            Some(fault(3, None, FaultKind::Dominant)),
        );
        let expected = Wave::default()
            .sent(&frame, 4)
            .recessive(6) // 4..=9: the transmitter went recessive
            .dominant(6)
            .recessive(8 + 3)
            .acked_frame_to_end(&frame); // retry at 27
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(errors(&outcome), vec![vec![(9, Detected::Stuff)]; 3]);
        assert_eq!(counters(&outcome), vec![(0, 1), (0, 0), (0, 0)]);
        assert_eq!(outcome.attempts, 2);
        assert_eq!(received_at(&outcome, 2), vec![27 + A_VALIDITY]);
    }

    // ---- CRC, ACK and form errors ----------------------------------------------------------

    /// CR-01: receiver 1 reads CRC bit 10 inverted (stuffing unchanged): no ACK from it, CRC error
    /// at the ACK delimiter, flag from EOF bit 1 (48..=53). The others see EOF bit 1 dominant
    /// (form error, flags 49..=54): receiver 1 gets rule 2 at 54.
    #[test]
    fn cr_01_crc_error_at_one_receiver() {
        let frame = frame_a();
        let outcome = run(
            &scenario(3, frame, 9, 9),
            Some(fault(A_CRC_BIT_10, Some(1), FaultKind::Flip)),
        );
        let expected = Wave::default()
            .bits(acked(&frame)[..A_EOF].to_vec())
            .dominant(7) // 48..=54
            .recessive(8 + 3) // 55..=65
            .acked_frame_to_end(&frame); // retry at 66
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(outcome.nodes[1].drive[A_ACK_SLOT], RECESSIVE, "no ACK");
        assert_eq!(outcome.nodes[2].drive[A_ACK_SLOT], DOMINANT);
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(A_EOF, Detected::Form)],
                vec![(A_ACK_DELIM, Detected::Crc)],
                vec![(A_EOF, Detected::Form)]
            ]
        );
        // tx 9+8−1; rx1 9+1+8−1; rx2 9−1+1−1.
        assert_eq!(counters(&outcome), vec![(16, 9), (9, 17), (9, 8)]);
        assert_eq!(received_at(&outcome, 1), vec![66 + A_VALIDITY]);
        assert_eq!(received_at(&outcome, 2), vec![66 + A_VALIDITY]);
    }

    /// AK-01: the only receiver sees a CRC error, nobody acknowledges: ACK error at the ACK slot,
    /// flag from the ACK delimiter (47..=52); the receiver sees the ACK delimiter dominant (form
    /// error, flag 48..=53); retransmission at ACK slot + 19.
    #[test]
    fn ak_01_ack_error_without_acknowledging_receiver() {
        let frame = frame_a();
        let outcome = run(
            &scenario(2, frame, 9, 9),
            Some(fault(A_CRC_BIT_10, Some(1), FaultKind::Flip)),
        );
        let expected = Wave::default()
            .sent(&frame, A_ACK_DELIM)
            .dominant(7) // 47..=53
            .recessive(8 + 3) // 54..=64
            .acked_frame_to_end(&frame); // retry at 65
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(A_ACK_SLOT, Detected::Ack)],
                vec![(A_ACK_DELIM, Detected::Form)]
            ]
        );
        assert_eq!(counters(&outcome), vec![(16, 9), (9, 9)]);
        assert_eq!(received_at(&outcome, 1), vec![A_ACK_SLOT + 19 + A_VALIDITY]);
    }

    /// AK-04 (a) / AK-05: a passive transmitter alone on the bus: ACK error, passive flag,
    /// delimiter, intermission and suspend: the next SOF is at ACK slot + 26; TEC stays 128.
    #[test]
    fn ak_04_passive_transmitter_alone_keeps_its_tec() {
        let frame = frame_a();
        let outcome = simulate(&scenario(1, frame, 128, 0), None, 200);
        assert_eq!(outcome.bus.len(), 200);
        let period = A_ACK_SLOT + 26;
        let mut expected = Wave::default();
        for _ in 0..3 {
            expected = expected.sent(&frame, A_ACK_SLOT + 1).recessive(25);
        }
        assert_eq!(outcome.bus, expected.0[..200].to_vec());
        assert_eq!(
            outcome.nodes[0].errors,
            vec![
                (A_ACK_SLOT, Detected::Ack),
                (period + A_ACK_SLOT, Detected::Ack),
                (2 * period + A_ACK_SLOT, Detected::Ack)
            ]
        );
        assert_eq!(counters(&outcome), vec![(128, 0)]);
        assert!(outcome.nodes[0].error_passive && !outcome.transmitted);
        assert_eq!(outcome.attempts, 3);
    }

    /// AK-04 (b): the active receiver's CRC error flag (48..=53) falls into the passive
    /// transmitter's flag: TEC +8; the passive flag completes on those 6 dominant bits;
    /// suspend, then the retry at 73.
    #[test]
    fn ak_04_passive_transmitter_dominant_bit_in_its_flag() {
        let frame = frame_a();
        let mut scenario = scenario(2, frame, 0, 0);
        scenario.tec[0] = 128;
        let outcome = run(
            &scenario,
            Some(fault(A_CRC_BIT_10, Some(1), FaultKind::Flip)),
        );
        let expected = Wave::default()
            .sent(&frame, A_ACK_DELIM + 1)
            .dominant(6) // 48..=53
            .recessive(8 + 3 + 8) // 54..=72
            .acked_frame_to_end(&frame);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(A_ACK_SLOT, Detected::Ack)],
                vec![(A_ACK_DELIM, Detected::Crc)]
            ]
        );
        assert_eq!(counters(&outcome), vec![(135, 0), (0, 0)]);
        assert_eq!(received_at(&outcome, 1), vec![73 + A_VALIDITY]);
    }

    /// AK-04 (a) with a passive receiver: both flags are recessive, the transmitter's TEC does
    /// not change (then −1 at success); retry at ACK slot + 26.
    #[test]
    fn ak_04_passive_transmitter_no_dominant_bit_in_its_flag() {
        let frame = frame_a();
        let mut scenario = scenario(2, frame, 128, 128);
        scenario.tec[1] = 0;
        scenario.rec[0] = 0;
        let outcome = run(
            &scenario,
            Some(fault(A_CRC_BIT_10, Some(1), FaultKind::Flip)),
        );
        let expected = Wave::default()
            .sent(&frame, A_ACK_SLOT + 1)
            .recessive(25)
            .acked_frame_to_end(&frame);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(counters(&outcome), vec![(127, 0), (0, 127)]);
        assert!(!outcome.nodes[0].error_passive && !outcome.nodes[1].error_passive);
        assert_eq!(received_at(&outcome, 1), vec![A_ACK_SLOT + 26 + A_VALIDITY]);
    }

    /// AK-03: the receiver's dominant ACK read recessive is a bit error (no REC decrement).
    #[test]
    fn ak_03_receiver_ack_read_recessive() {
        let frame = frame_a();
        let outcome = run(
            &scenario(3, frame, 0, 9),
            Some(fault(A_ACK_SLOT, Some(1), FaultKind::Recessive)),
        );
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(A_ACK_DELIM, Detected::Form)],
                vec![(A_ACK_SLOT, Detected::Bit)],
                vec![(A_ACK_DELIM, Detected::Form)]
            ]
        );
        // rx1: 9+1, rule 2 (others' flags 48..=53 after its flag 47..=52), −1 at the retry;
        // rx2: 9 −1 (ACK) +1 (form) −1 (retry).
        assert_eq!(counters(&outcome), vec![(7, 9), (0, 17), (0, 8)]);
    }

    /// FE-01 / FE-04: CRC delimiter read dominant by every node: form error everywhere, retry at
    /// e + 18.
    #[test]
    fn fe_01_04_form_error_at_crc_delimiter() {
        let frame = frame_a();
        let e = A_CRC_DELIM;
        let outcome = run(
            &scenario(3, frame, 9, 9),
            Some(fault(e, None, FaultKind::Dominant)),
        );
        let expected = Wave::default()
            .sent(&frame, e + 1)
            .dominant(6)
            .recessive(8 + 3)
            .acked_frame_to_end(&frame);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(errors(&outcome), vec![vec![(e, Detected::Form)]; 3]);
        assert_eq!(counters(&outcome), vec![(16, 9), (9, 9), (9, 9)]);
    }

    /// FE-01 at one receiver: its flag (46..=51) covers the ACK slot and makes the others see a
    /// dominant ACK delimiter (form error, flags 48..=53): rule 2 for the first receiver.
    #[test]
    fn fe_01_form_error_at_crc_delimiter_of_one_receiver() {
        let frame = frame_a();
        let outcome = run(
            &scenario(3, frame, 9, 9),
            Some(fault(A_CRC_DELIM, Some(1), FaultKind::Dominant)),
        );
        let expected = Wave::default()
            .sent(&frame, A_CRC_DELIM + 1)
            .dominant(8) // 46..=53
            .recessive(8 + 3) // 54..=64
            .acked_frame_to_end(&frame);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(A_ACK_DELIM, Detected::Form)],
                vec![(A_CRC_DELIM, Detected::Form)],
                vec![(A_ACK_DELIM, Detected::Form)]
            ]
        );
        // rx1: 9+1+8 (rule 2) −1; rx2: 9 −1 (its ACK went out) +1 −1.
        assert_eq!(counters(&outcome), vec![(16, 9), (9, 17), (9, 8)]);
    }

    // ---- EOF and overload --------------------------------------------------------------------

    /// FR-06: receiver 1 sees the last EOF bit dominant: the frame is already valid (delivered at
    /// EOF bit 6); overload flag 55..=60; the others see intermission bit 1 dominant (overload
    /// flags 56..=61); no error, counters as for a success.
    #[test]
    fn fr_06_last_eof_bit_dominant_at_a_receiver() {
        let frame = frame_a();
        let outcome = run(
            &scenario(3, frame, 9, 9),
            Some(fault(A_LAST_EOF, Some(1), FaultKind::Dominant)),
        );
        let expected = Wave::default()
            .bits(acked(&frame))
            .dominant(7) // 55..=61
            .recessive(8 + 3 + IDLE_BITS_AT_END);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(errors(&outcome), vec![vec![]; 3]);
        assert_eq!(counters(&outcome), vec![(8, 9), (9, 8), (9, 8)]);
        assert_eq!(received_at(&outcome, 1), vec![A_VALIDITY]);
        assert_eq!(received_at(&outcome, 2), vec![A_VALIDITY]);
        assert!(outcome.transmitted);
        assert_eq!(outcome.attempts, 1);
    }

    /// FR-07 and the known inconsistency: receiver 1 sees EOF bit 6 dominant (form error, flag
    /// 54..=59); the transmitter sees its last EOF bit dominant (form error, flag 55..=60) and
    /// retransmits; receiver 2 had delivered the frame at EOF bit 6 and sends an overload flag:
    /// it receives the frame twice, receiver 1 once.
    #[test]
    fn fr_07_eof_bit_6_dominant_at_a_receiver_double_reception() {
        let frame = frame_a();
        let outcome = run(
            &scenario(3, frame, 9, 9),
            Some(fault(A_VALIDITY, Some(1), FaultKind::Dominant)),
        );
        let expected = Wave::default()
            .bits(acked(&frame))
            .dominant(6) // 55..=60 (bit 54 is dominant too: 54..=60)
            .recessive(8 + 3) // 61..=71
            .acked_frame_to_end(&frame); // retry at 72
        let mut expected = expected.0;
        expected[A_LAST_EOF] = DOMINANT;
        assert_eq!(outcome.bus, expected);
        assert_eq!(
            errors(&outcome),
            vec![
                vec![(A_LAST_EOF, Detected::Form)],
                vec![(A_VALIDITY, Detected::Form)],
                vec![]
            ]
        );
        assert_eq!(received_at(&outcome, 1), vec![72 + A_VALIDITY]);
        assert_eq!(received_at(&outcome, 2), vec![A_VALIDITY, 72 + A_VALIDITY]);
        // tx 9+8−1; rx1 9−1+1+8 (rule 2 at 60)−1; rx2 9−1−1.
        assert_eq!(counters(&outcome), vec![(16, 9), (9, 16), (9, 7)]);
        assert_eq!(outcome.attempts, 2);
    }

    /// FT-06 / OV-01: intermission bit 1 dominant for every node after a successful frame:
    /// overload flags, the frame stays successful (TEC 9 → 8), no retransmission.
    #[test]
    fn ft_06_intermission_bit_1_dominant() {
        let frame = frame_a();
        let outcome = run(
            &scenario(2, frame, 9, 9),
            Some(fault(A_LEN, None, FaultKind::Dominant)),
        );
        let expected = Wave::default()
            .bits(acked(&frame))
            .recessive(1)
            .dominant(6)
            .recessive(8 + 3 + IDLE_BITS_AT_END);
        assert_eq!(outcome.bus, expected.0);
        assert_eq!(errors(&outcome), vec![vec![]; 2]);
        assert_eq!(counters(&outcome), vec![(8, 9), (9, 8)]);
        assert!(outcome.transmitted);
        assert_eq!(outcome.attempts, 1);
    }

    /// FT-05: the transmitter alone sees its last EOF bit dominant: form error, retransmission;
    /// the receivers had delivered the frame and see an overload condition at intermission 1.
    #[test]
    fn ft_05_transmitter_last_eof_bit_dominant() {
        let frame = frame_a();
        let outcome = run(
            &scenario(2, frame, 0, 0),
            Some(fault(A_LAST_EOF, Some(0), FaultKind::Dominant)),
        );
        assert_eq!(
            errors(&outcome),
            vec![vec![(A_LAST_EOF, Detected::Form)], vec![]]
        );
        assert_eq!(counters(&outcome), vec![(7, 0), (0, 0)]);
        // Flag 55..=60, receiver's overload flag 56..=61, delimiters from 62, retry at 73.
        assert_eq!(received_at(&outcome, 1), vec![A_VALIDITY, 73 + A_VALIDITY]);
    }

    // ---- bus-off -----------------------------------------------------------------------------

    /// BO-01/BO-02: TEC 250 + 8 > 255: bus-off at the error, TEC 127, REC 0, recessive from then
    /// on, the request ends without success.
    #[test]
    fn bo_01_bus_off_ends_the_request() {
        let frame = frame_a();
        let mut scenario = scenario(2, frame, 0, 0);
        scenario.tec[0] = 250;
        scenario.rec[0] = 5;
        let e = A_DATA_STUFF;
        let outcome = run(&scenario, Some(fault(e, None, FaultKind::Flip)));
        let expected = Wave::default()
            .sent(&frame, e + 1)
            .dominant(6)
            .recessive(8 + 3 + IDLE_BITS_AT_END);
        assert_eq!(outcome.bus, expected.0);
        let tx = &outcome.nodes[0];
        assert!(tx.bus_off && !tx.error_passive);
        assert_eq!((tx.tec, tx.rec), (127, 0));
        assert!(tx.drive[e + 1..].iter().all(|&d| d == RECESSIVE));
        assert!(!outcome.transmitted);
        assert_eq!(outcome.attempts, 1);
        assert_eq!(outcome.nodes[1].rec, 1);
    }

    // ---- one node fed with chosen levels (scenarios that need more than one fault) ------

    /// Node `index` of a 2-node scenario sending frame A from node 0.
    fn lone_node(index: usize, tec: u8, rec: u8) -> Node {
        Node::new(&scenario(2, frame_a(), tec, rec), index)
    }

    /// Feeds the levels of `seen` to `node`, one per bit, after the bits it has already seen.
    fn feed(node: &mut Node, seen: Wave) {
        let start = node.drive.len();
        for (offset, level) in seen.0.into_iter().enumerate() {
            node.step(start + offset, level);
        }
    }

    /// Frame A up to bit 24, then bit 25 and the 6 bits of the node's active flag dominant: a
    /// stuff error at 25 for a receiver, a bit error at 25 for the transmitter; flag 26..=31.
    fn error_at_25_and_active_flag() -> Wave {
        Wave::default()
            .sent(&frame_a(), A_DATA_STUFF)
            .dominant(1 + 6)
    }

    /// Recessive bits after an error frame, enough for a receiver to end in bus idle.
    const TAIL: usize = 40;
    /// Recessive bits after an error flag up to the end of intermission: a transmitter would
    /// retry at the next bit (and see a bit error on its SOF, nobody driving it here).
    const TO_RETRY: usize = 8 + 3;

    /// The recessive tail after an error frame: the end of intermission for a transmitter.
    fn tail(index: usize) -> usize {
        if index == 0 {
            TO_RETRY
        } else {
            TAIL
        }
    }

    #[test]
    fn ec_03_04_09_rules_2_and_6_for_a_receiver() {
        // (dominant bits after the active flag, REC): rule 2 once, rule 6 at the 8th and 16th.
        for (dominant, rec) in [(0, 1), (1, 9), (7, 9), (8, 17), (16, 25)] {
            let mut node = lone_node(1, 0, 0);
            feed(
                &mut node,
                error_at_25_and_active_flag()
                    .dominant(dominant)
                    .recessive(TAIL),
            );
            assert_eq!(node.errors, vec![(A_DATA_STUFF, Detected::Stuff)]);
            assert_eq!(node.rec, rec, "{dominant} dominant bits");
            assert_eq!(node.tec, 0);
            assert!(node.drive[32..].iter().all(|&d| d == RECESSIVE));
            assert!(node.is_quiet());
        }
    }

    #[test]
    fn ec_10_rule_6_for_the_transmitter() {
        let mut node = lone_node(0, 0, 0);
        feed(
            &mut node,
            error_at_25_and_active_flag().dominant(16).recessive(8 + 3),
        );
        assert_eq!(node.errors, vec![(A_DATA_STUFF, Detected::Bit)]);
        assert_eq!((node.tec, node.rec), (24, 0));
        // Delimiter 48..=55, intermission 56..=58: the retry's SOF is driven in bit 59.
        assert_eq!(node.drive(), DOMINANT);
        assert_eq!(node.attempts, 2);
    }

    #[test]
    fn ec_11_rule_6_after_a_passive_flag() {
        for (dominant, delta) in [(1, 8), (6, 8), (8, 16), (9, 16), (16, 24)] {
            let mut node = lone_node(0, 128, 0);
            let seen = Wave::default()
                .sent(&frame_a(), A_DATA_STUFF)
                .dominant(1)
                .recessive(6) // passive flag 26..=31
                .dominant(dominant)
                .recessive(TO_RETRY + 8);
            feed(&mut node, seen);
            assert_eq!(node.tec, 128 + delta, "{dominant} dominant bits");
            assert!(node.drive[A_DATA_STUFF + 1..]
                .iter()
                .all(|&d| d == RECESSIVE));
        }
    }

    #[test]
    fn ep_06_passive_transmitter_retries_at_e_plus_26() {
        let mut node = lone_node(0, 128, 0);
        let seen = Wave::default()
            .sent(&frame_a(), A_DATA_STUFF)
            .dominant(1)
            .recessive(6 + 8 + 3 + 8);
        feed(&mut node, seen);
        assert_eq!(node.drive.len(), A_DATA_STUFF + 26);
        assert_eq!(node.drive(), DOMINANT, "SOF at e + 26");
        assert_eq!(node.tec, 136);
    }

    #[test]
    fn ep_01_02_passive_flag_waits_for_six_equal_bits() {
        let mut node = lone_node(1, 0, 128);
        let seen = Wave::default()
            .sent(&frame_a(), A_DATA_STUFF)
            .dominant(1) // stuff error at 25
            .dominant(3) // 26..=28
            .recessive(2) // 29..=30: the count restarts
            .dominant(6) // 31..=36: flag complete
            .recessive(8 + 2); // delimiter 37..=44, intermission 45..=46
        feed(&mut node, seen);
        assert_eq!(node.state, State::Intermission { bits: 2 });
        assert_eq!(
            node.rec, 129,
            "no rule 2: the flag ended on the dominant bits"
        );
        assert!(node.drive.iter().all(|&d| d == RECESSIVE));
    }

    #[test]
    fn be_03_bit_error_in_own_active_flag() {
        // (node, TEC, REC): receiver +1 +8, transmitter +8 +8.
        for (index, counters) in [(1, (0, 9)), (0, (16, 0))] {
            let mut node = lone_node(index, 0, 0);
            let seen = Wave::default()
                .sent(&frame_a(), A_DATA_STUFF)
                .dominant(3) // error at 25, flag bits 1 and 2
                .recessive(1) // flag bit 3 (28) read recessive
                .dominant(6) // the new flag 29..=34
                .recessive(tail(index));
            feed(&mut node, seen);
            assert_eq!(node.errors[1], (28, Detected::Bit));
            assert_eq!((node.tec, node.rec), counters);
            assert!(node.drive[26..35].iter().all(|&d| d == DOMINANT));
            assert_eq!(node.drive[35], RECESSIVE);
        }
    }

    #[test]
    fn fe_05_error_delimiter_bit_2_dominant() {
        for (index, counters) in [(1, (0, 2)), (0, (16, 0))] {
            let mut node = lone_node(index, 0, 0);
            let seen = error_at_25_and_active_flag()
                .recessive(1) // delimiter bit 1 (32)
                .dominant(1 + 6) // bit 2 (33): form error; flag 34..=39
                .recessive(tail(index));
            feed(&mut node, seen);
            assert_eq!(node.errors[1], (33, Detected::Form));
            assert_eq!((node.tec, node.rec), counters);
        }
    }

    /// Frame A received up to the stuff error at 25, flag, 7 delimiter bits and a dominant 8th
    /// delimiter bit (39): overload flag 40..=45.
    fn overload_after_error_delimiter() -> Wave {
        error_at_25_and_active_flag().recessive(7).dominant(1 + 6)
    }

    #[test]
    fn fe_06_ov_03_04_error_delimiter_bit_8_dominant() {
        // (dominant bits after the overload flag, REC): tolerated up to 7, rule 6 from 8 on.
        for (dominant, rec) in [(0, 1), (7, 1), (8, 9), (16, 17)] {
            let mut node = lone_node(1, 0, 0);
            let seen = overload_after_error_delimiter()
                .dominant(dominant)
                .recessive(TAIL);
            feed(&mut node, seen);
            assert_eq!(node.errors.len(), 1, "no new error");
            assert!(node.drive[40..46].iter().all(|&d| d == DOMINANT));
            assert_eq!(node.drive[46], RECESSIVE);
            assert_eq!(node.rec, rec);
        }
    }

    #[test]
    fn be_04_bit_error_in_own_overload_flag() {
        let mut node = lone_node(1, 0, 0);
        let seen = error_at_25_and_active_flag()
            .recessive(7)
            .dominant(1 + 2) // overload flag 40, 41
            .recessive(1) // 42 read recessive
            .dominant(6) // error flag 43..=48
            .recessive(TAIL);
        feed(&mut node, seen);
        assert_eq!(node.errors[1], (42, Detected::Bit));
        assert_eq!(node.rec, 1 + 8);
    }

    #[test]
    fn fe_07_08_overload_delimiter() {
        // Overload delimiter 46..=53: bit 2 dominant is a form error, bit 8 a new overload flag.
        let mut node = lone_node(1, 0, 0);
        let seen = overload_after_error_delimiter()
            .recessive(1)
            .dominant(1 + 6)
            .recessive(TAIL);
        feed(&mut node, seen);
        assert_eq!(node.errors[1], (47, Detected::Form));
        assert_eq!(node.rec, 2);

        let mut node = lone_node(1, 0, 0);
        let seen = overload_after_error_delimiter()
            .recessive(7)
            .dominant(1 + 6)
            .recessive(TAIL);
        feed(&mut node, seen);
        assert_eq!(node.errors.len(), 1);
        assert!(node.drive[54..60].iter().all(|&d| d == DOMINANT));
        assert_eq!(node.rec, 1);
    }

    #[test]
    fn if_03_ov_07_pending_transmitter_starts_without_sof_on_intermission_bit_3() {
        let frame = frame_a();
        let mut node = lone_node(0, 0, 0);
        // Delimiter 32..=39, intermission 40..=42; a dominant intermission bit 3 (42) is a SOF.
        let seen = error_at_25_and_active_flag().recessive(8 + 2).dominant(1);
        feed(&mut node, seen);
        assert_eq!(node.attempts, 2);
        assert!(matches!(
            node.state,
            State::Transmitting { position: 1, .. }
        ));
        feed(&mut node, Wave::default().bits(acked(&frame)[1..].to_vec()));
        assert_eq!(
            node.drive[43..],
            encode(&frame).bits.iter().by_vals().collect::<Vec<_>>()[1..]
        );
        assert!(node.transmitted);
        assert_eq!(node.tec, 7);
    }

    #[test]
    fn ep_07_08_passive_transmitter_receives_the_frame_that_starts_first() {
        let other = Frame::data(Id::Standard(0x0F0), &[0x5A, 0xFF]).unwrap();
        let other_bits = acked(&other);
        let other_validity = encode(&other).position(Field::Eof, 5).unwrap();
        // Intermission bit 3 (EP-08) and a suspend bit (EP-07).
        for sof in [42, 45] {
            let mut node = lone_node(0, 128, 0);
            let seen = Wave::default()
                .sent(&frame_a(), A_DATA_STUFF)
                .dominant(1)
                .recessive(sof - (A_DATA_STUFF + 1)) // passive flag from 26, delimiter, ...
                .bits(other_bits.clone())
                .recessive(3);
            feed(&mut node, seen);
            assert_eq!(node.received, vec![(sof + other_validity, other)]);
            let ack = encode(&other).position(Field::AckSlot, 0).unwrap();
            assert_eq!(node.drive[sof + ack], DOMINANT, "passive nodes ACK");
            assert_eq!(node.attempts, 2, "no suspend: it was a receiver");
            assert_eq!(node.drive(), DOMINANT, "SOF right after intermission");
        }
    }

    #[test]
    fn ec_13_rec_above_127_is_set_to_127_on_success_and_saturates_at_255() {
        let mut node = lone_node(1, 0, 250);
        feed(
            &mut node,
            error_at_25_and_active_flag().dominant(1).recessive(TAIL),
        );
        assert_eq!(node.rec, 255, "250 + 1 + 8 saturates");
        feed(
            &mut node,
            Wave::default().bits(acked(&frame_a())).recessive(5),
        );
        assert_eq!(node.rec, 127);
        assert!(!node.error_passive());
        assert_eq!(node.received.len(), 1);
    }

    // ---- every single fault -----------------------------------------------------------------

    /// Every fault kind at every bit of the first attempt and its interframe space, on the bus
    /// and at each node: the run ends, the bus is the AND of the drives, the frame finally goes
    /// out, every receiver delivers it once or twice (the second time at the same bit as the
    /// others), and the transmitter needs at most two attempts.
    #[test]
    fn every_single_fault_ends_with_the_frame_delivered() {
        let frames = [
            frame_a(),
            Frame::data(Id::Standard(0), &[]).unwrap(),
            Frame::remote(Id::Extended(0x1555_5555), 3).unwrap(),
            Frame::data(Id::Extended(0x0ABC_DEF0), &[0xFF, 0x00, 0x1F, 0xE0]).unwrap(),
        ];
        let kinds = [FaultKind::Flip, FaultKind::Dominant, FaultKind::Recessive];
        for frame in frames {
            let len = encode(&frame).len();
            let scenario = scenario(3, frame, 0, 0);
            for bit in 0..len + 20 {
                for node in [None, Some(0), Some(1), Some(2)] {
                    for kind in kinds {
                        let fault = fault(bit, node, kind);
                        let outcome = run(&scenario, Some(fault));
                        check_single_fault_outcome(&frame, &fault, &outcome);
                    }
                }
            }
        }
    }

    fn check_single_fault_outcome(frame: &Frame, fault: &Fault, outcome: &Outcome) {
        let context = format!("{frame} {fault:?}");
        assert!(outcome.bus.len() < MAX_BITS, "{context}: no end");
        for (bit, &level) in outcome.bus.iter().enumerate() {
            let and = outcome.nodes.iter().all(|n| n.drive[bit]);
            assert_eq!(level, and, "{context}: bus at {bit}");
        }
        assert!(outcome.transmitted, "{context}");
        assert!((1..=2).contains(&outcome.attempts), "{context}");
        let last: Vec<(usize, Frame)> = outcome.nodes[1..]
            .iter()
            .map(|n| *n.received.last().expect("delivered"))
            .collect();
        assert!(last.iter().all(|&r| r == last[0]), "{context}: {last:?}");
        assert_eq!(last[0].1, *frame, "{context}");
        for node in &outcome.nodes[1..] {
            assert!(node.received.len() <= 2, "{context}");
        }
        assert!(outcome
            .nodes
            .iter()
            .all(|n| !n.bus_off && n.errors.len() <= 2));
    }

    #[test]
    fn fault_kinds_change_only_the_level_seen() {
        assert!(!FaultKind::Flip.apply(RECESSIVE));
        assert!(FaultKind::Flip.apply(DOMINANT));
        assert_eq!(FaultKind::Dominant.apply(RECESSIVE), DOMINANT);
        assert_eq!(FaultKind::Recessive.apply(DOMINANT), RECESSIVE);
        let local = fault(4, Some(1), FaultKind::Flip);
        assert_eq!(local.seen(4, 1, RECESSIVE), DOMINANT);
        assert_eq!(local.seen(4, 0, RECESSIVE), RECESSIVE);
        assert_eq!(local.seen(5, 1, RECESSIVE), RECESSIVE);
        let global = fault(4, None, FaultKind::Dominant);
        assert_eq!(global.seen(4, 7, RECESSIVE), DOMINANT);
    }
}
