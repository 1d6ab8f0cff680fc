//! A CANopen (CiA 301) stack, devices and a master, independent of the hardware: it takes the CAN
//! frames its node receives and the passing of time, and returns the frames the node sends. In the
//! simulator it is the firmware of a node, reaching the bus only through the SJA1000 driver model and
//! the RTL controller (`sim::scenario`'s CANopen nodes), but nothing here knows about that.
//!
//! * [`eds`]: electronic data sheets (CiA 306), with file:line errors;
//! * [`od`]: the object dictionary (index, sub-index, data type, access, limits, value);
//! * [`sdo`]: the SDO server (expedited and segmented transfers, the abort codes), [`sdo_block`]
//!   its block transfers, [`sdo_client`] and [`sdo_block_client`] the client (the master's side);
//! * [`nmt`]: the NMT slave state machine and the heartbeat producer;
//! * [`pdo`]: PDO mapping checks, SYNC-driven and event-driven TPDOs, RPDOs;
//! * [`error_control`]: the SYNC producer, the EMCY producer and the heartbeat consumer;
//! * [`time_stamp`]: the TIME object (TIME_OF_DAY), consumed by devices that 1012h tells to;
//! * [`guarding`]: node guarding and life guarding;
//! * [`device`]: all of it as one device with a node-ID;
//! * [`master`]: a CANopen master (NMT master, SDO client, SYNC and TIME producer) running a
//!   script, with [`node_table`], its heartbeat and EMCY consumer;
//! * [`trace`]: CANopen frames in words, for bus logs.
//!
//! Every protocol value comes from CiA 301 (v4.2.0), cited where it is used.
#![warn(missing_docs)]

pub mod device;
pub mod eds;
pub mod error_control;
pub mod guarding;
pub mod master;
pub mod nmt;
pub mod node_table;
pub mod od;
pub mod pdo;
pub mod sdo;
pub mod sdo_block;
pub mod sdo_block_client;
pub mod sdo_client;
pub mod time_stamp;
pub mod trace;

/// A CAN frame with an 11-bit identifier, as CANopen's predefined connection set uses them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CanFrame {
    /// The COB-ID (11 bits).
    pub id: u16,
    /// A remote frame (no data; `data.len()` is its DLC).
    pub remote: bool,
    /// Up to 8 data bytes.
    pub data: Vec<u8>,
}

impl CanFrame {
    /// A data frame.
    pub fn new(id: u16, data: &[u8]) -> CanFrame {
        debug_assert!(id <= 0x7FF && data.len() <= 8);
        CanFrame {
            id,
            remote: false,
            data: data.to_vec(),
        }
    }
}
