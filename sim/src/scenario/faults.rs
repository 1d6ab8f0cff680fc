//! Faults of a scenario: what goes wrong, where and for how long, and how each becomes a window of
//! the simulation engine.
//!
//! A fault is located by time, or by frame: the `frame`-th start of frame on the bus (counting
//! every frame, retransmissions and frames destroyed by errors included), then a field and a bit
//! index in it. The bit is found from the golden encoding of the frame that wins the arbitration
//! (the bus carries its bits, stuff bits included) and the bit time of its sender. A fault on the
//! bus is seen by every node (and in the traced `bus`); a fault limited to some nodes is seen only
//! by their receivers, each through its own propagation delay.

use crate::engine::bus::{BusFault, Drive};
use crate::engine::{DeviceId, Engine};
use golden::frame::{encode, Field, Frame, RECESSIVE};

/// What a fault does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// The level is inverted.
    Flip,
    /// The level is forced (`false` = dominant).
    Force(bool),
    /// A short pulse: the level is forced to `Some(level)`, or inverted with `None`.
    Glitch(Option<bool>),
    /// The node is cut from the bus: what it drives does not reach the bus, and it sees the bus
    /// recessive.
    Disconnect(usize),
    /// The node's transmitter drives dominant whatever its controller says.
    StuckDominant(usize),
}

/// Where a fault begins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// At a time.
    At(u64),
    /// At the start of a bit of a frame on the bus.
    Bit {
        /// The frame: 1 for the first start of frame on the bus.
        frame: u64,
        /// The field.
        field: Field,
        /// The bit in the field (0: the first bit sent), stuff bits not counted.
        index: u16,
    },
}

/// A fault of the scenario.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fault {
    /// The line of the scenario file that describes it (named in messages).
    pub line: usize,
    /// What it does.
    pub kind: FaultKind,
    /// Where it begins (before `offset_fs`).
    pub place: Place,
    /// Delay from the place to the start of the fault.
    pub offset_fs: u64,
    /// How long it lasts.
    pub duration_fs: u64,
    /// The nodes that see it (flip, force, glitch); empty: it is on the bus.
    pub nodes: Vec<usize>,
}

/// A node as the faults need it.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    /// The node's device.
    pub id: DeviceId,
    /// Its propagation delay.
    pub delay_fs: u64,
}

/// The frame among `contenders` that wins the arbitration (its bits are the smallest, dominant
/// first), and the wire position of bit `index` of `field` in it.
pub fn locate(contenders: &[Frame], field: Field, index: u16) -> Result<(Frame, usize), String> {
    let winner = contenders
        .iter()
        .map(|f| (encode(f), *f))
        .min_by(|(a, _), (b, _)| a.bits.iter().by_vals().cmp(b.bits.iter().by_vals()))
        .ok_or("no node was transmitting it (it began with a disturbance)")?;
    let position = winner
        .0
        .position(field, index)
        .ok_or_else(|| format!("it is {} and has no {field} bit {index}", winner.1))?;
    Ok((winner.1, position))
}

/// Puts `fault` into `engine` from `start_fs` on; `targets` are the scenario's nodes.
pub fn install(engine: &mut Engine, fault: &Fault, start_fs: u64, targets: &[Target]) {
    let end_fs = start_fs + fault.duration_fs;
    let level = match fault.kind {
        FaultKind::Flip | FaultKind::Glitch(None) => None,
        FaultKind::Force(level) | FaultKind::Glitch(Some(level)) => Some(level),
        FaultKind::Disconnect(node) => {
            let id = targets[node].id;
            engine.override_drive(id, start_fs, end_fs, Drive::Recessive);
            engine.disturb_rx(id, start_fs, end_fs, RECESSIVE);
            return;
        }
        FaultKind::StuckDominant(node) => {
            engine.override_drive(targets[node].id, start_fs, end_fs, Drive::Dominant);
            return;
        }
    };
    if fault.nodes.is_empty() {
        let bus_fault = level.map_or(BusFault::Invert, BusFault::Force);
        engine.fault_bus(start_fs, end_fs, bus_fault);
        return;
    }
    for &node in &fault.nodes {
        let Target { id, delay_fs } = targets[node];
        let (from, to) = (start_fs + delay_fs, end_fs + delay_fs);
        match level {
            Some(level) => engine.disturb_rx(id, from, to, level),
            None => engine.invert_rx(id, from, to),
        }
    }
}

impl FaultKind {
    /// A short description: `flip`, `force dominant`, `glitch`, `disconnect`, `stuck dominant`.
    pub fn name(&self) -> &'static str {
        match self {
            FaultKind::Flip => "flip",
            FaultKind::Force(RECESSIVE) => "force recessive",
            FaultKind::Force(_) => "force dominant",
            FaultKind::Glitch(None) => "glitch (inverted)",
            FaultKind::Glitch(Some(RECESSIVE)) => "glitch (recessive)",
            FaultKind::Glitch(Some(_)) => "glitch (dominant)",
            FaultKind::Disconnect(_) => "disconnect",
            FaultKind::StuckDominant(_) => "stuck dominant",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use golden::frame::Id;

    fn frame(id: u16, data: &[u8]) -> Frame {
        Frame::data(Id::standard(id).unwrap(), data).unwrap()
    }

    #[test]
    fn the_lowest_identifier_wins_and_stuff_bits_count_in_the_position() {
        let low = frame(0x000, &[0xFF]);
        let (winner, position) = locate(&[frame(0x123, &[1]), low], Field::Dlc, 0).unwrap();
        assert_eq!(winner, low);
        // SOF, 11 dominant identifier bits (two stuff bits among them), RTR, IDE, r0 and a third
        // stuff bit after them.
        assert_eq!(position, 1 + 11 + 2 + 3 + 1);
    }

    #[test]
    fn missing_bits_and_missing_transmitters_are_errors() {
        let error = locate(&[frame(0x123, &[1])], Field::Data, 8).unwrap_err();
        assert_eq!(error, "it is 123#01 and has no data bit 8");
        assert!(locate(&[], Field::Crc, 0)
            .unwrap_err()
            .contains("disturbance"));
    }
}
