//! Worst-case response-time analysis of CAN message sets (`cansim rta`), checked against the
//! cycle-accurate bus.
//!
//! * [`message_set`]: the TOML message-set format, validation, priority order.
//! * [`analysis`]: the classic recurrence and the corrected analysis of Davis, Burns, Bril and
//!   Lukkien (2007), side by side.
//! * [`simulate`]: each message's critical instant recreated on the cycle-accurate bus, one RTL
//!   CAN core per message; the observed worst-case responses beside both bounds.
//! * [`report`]: the text table and the CSV.
//!
//! See `docs/RTA.md` for the conventions (blocking, τbit, what C and a response time include).

pub mod analysis;
pub mod message_set;
pub mod report;
pub mod simulate;

/// A time in the message set's ticks: nanoseconds for a set with a bit rate, abstract units
/// (one tick per bit time) otherwise.
pub type Ticks = u64;
