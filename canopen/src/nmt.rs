//! NMT (CiA 301 7.2.8): the slave's state machine, the commands that drive it and the codes its
//! error-control messages (boot-up, heartbeat) carry.

/// The NMT states of a device (7.3.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtState {
    /// After power-on or a reset, until the boot-up message is sent.
    Initialisation,
    /// SDO, SYNC, TIME, EMCY, NMT and error control; no PDO.
    PreOperational,
    /// Every service.
    Operational,
    /// NMT and error control only.
    Stopped,
}

impl NmtState {
    /// The state byte of a heartbeat or guarding answer (7.2.8.3.2.1, Table 54): 00h boot-up,
    /// 04h stopped, 05h operational, 7Fh pre-operational.
    pub fn code(self) -> u8 {
        match self {
            NmtState::Initialisation => 0x00,
            NmtState::Stopped => 0x04,
            NmtState::Operational => 0x05,
            NmtState::PreOperational => 0x7F,
        }
    }

    /// Whether SDO requests are served in this state (Table 82: pre-operational and operational).
    pub fn serves_sdo(self) -> bool {
        matches!(self, NmtState::PreOperational | NmtState::Operational)
    }
}

/// An NMT command (7.2.8.3.1, on COB-ID 000h: the command specifier, then the node-ID, 0 for
/// every node).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtCommand {
    /// 01h.
    Start,
    /// 02h.
    Stop,
    /// 80h.
    EnterPreOperational,
    /// 81h: the whole object dictionary back to its defaults, then boot-up.
    ResetNode,
    /// 82h: the communication area (1000h–1FFFh) back to its defaults, then boot-up.
    ResetCommunication,
}

impl NmtCommand {
    /// The command of specifier `cs`.
    pub fn from_specifier(cs: u8) -> Option<NmtCommand> {
        Some(match cs {
            0x01 => NmtCommand::Start,
            0x02 => NmtCommand::Stop,
            0x80 => NmtCommand::EnterPreOperational,
            0x81 => NmtCommand::ResetNode,
            0x82 => NmtCommand::ResetCommunication,
            _ => return None,
        })
    }

    /// Its command specifier.
    pub fn specifier(self) -> u8 {
        match self {
            NmtCommand::Start => 0x01,
            NmtCommand::Stop => 0x02,
            NmtCommand::EnterPreOperational => 0x80,
            NmtCommand::ResetNode => 0x81,
            NmtCommand::ResetCommunication => 0x82,
        }
    }

    /// The state a device is in after the command (the resets pass through initialisation and
    /// its boot-up message to pre-operational).
    pub fn next_state(self) -> NmtState {
        match self {
            NmtCommand::Start => NmtState::Operational,
            NmtCommand::Stop => NmtState::Stopped,
            NmtCommand::EnterPreOperational
            | NmtCommand::ResetNode
            | NmtCommand::ResetCommunication => NmtState::PreOperational,
        }
    }
}
