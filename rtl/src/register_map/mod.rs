//! The SJA1000 register map's blocks: each owns its registers and their host access, and the
//! controller (`crate::can_controller`) wires them to the host port, the core, the transmit buffer,
//! the acceptance filter and the receive FIFO.
//!
//! - `host_decode`: which window an access hits, byte indices, the CMR strobes (combinational);
//! - `modes`: MOD / CR.RR, CDR, sleep and wake-up, CLKOUT, the core's mode inputs;
//! - `configuration`: BTR0, BTR1, OCR, EWLR;
//! - `interrupts`: IER, IR, the ALC and ECC captures, SR.ES, the BasicCAN RI latch;
//! - `register_read`: SR, the IR value, the read multiplexer, `rdata` and the interrupt line.

pub mod configuration;
pub mod host_decode;
pub mod interrupts;
pub mod modes;
pub mod register_read;
