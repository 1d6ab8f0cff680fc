//! The SJA1000 register map as seen by a host: addresses and bits of both maps, defined once.
//!
//! The controller's kernel reads the addresses through `Constant` fields built from these values
//! (a plain Rust constant inside a kernel would become an undeclared Verilog identifier); drivers,
//! the host model and the testbenches use them directly.

/// PeliCAN register addresses (CDR.7 = 1).
pub mod pelican {
    /// Mode register.
    pub const MOD: u8 = 0;
    /// Command register (write only).
    pub const CMR: u8 = 1;
    /// Status register.
    pub const SR: u8 = 2;
    /// Interrupt register.
    pub const IR: u8 = 3;
    /// Interrupt enable register.
    pub const IER: u8 = 4;
    /// Bus timing register 0.
    pub const BTR0: u8 = 6;
    /// Bus timing register 1.
    pub const BTR1: u8 = 7;
    /// Output control register.
    pub const OCR: u8 = 8;
    /// Arbitration lost capture.
    pub const ALC: u8 = 11;
    /// Error code capture.
    pub const ECC: u8 = 12;
    /// Error warning limit.
    pub const EWLR: u8 = 13;
    /// Receive error counter.
    pub const RXERR: u8 = 14;
    /// Transmit error counter.
    pub const TXERR: u8 = 15;
    /// First byte of the frame window: TX buffer (write) and RX buffer (read) in operating mode,
    /// ACR0 in reset mode.
    pub const FRAME: u8 = 16;
    /// Last byte of the frame window.
    pub const FRAME_LAST: u8 = 28;
    /// Acceptance code register 0 (reset mode; ACR1..3 follow).
    pub const ACR0: u8 = 16;
    /// Acceptance mask register 0 (reset mode; AMR1..3 follow).
    pub const AMR0: u8 = 20;
    /// Last acceptance mask register.
    pub const AMR3: u8 = 23;
    /// RX message counter.
    pub const RMC: u8 = 29;
    /// RX buffer start address.
    pub const RBSA: u8 = 30;
    /// Clock divider register.
    pub const CDR: u8 = 31;
    /// First byte of the RX FIFO RAM window (FIFO byte 0).
    pub const RX_RAM: u8 = 32;
    /// Last byte of the RX FIFO RAM window (FIFO byte 63).
    pub const RX_RAM_LAST: u8 = 95;
    /// First byte of the TX buffer RAM window.
    pub const TX_RAM: u8 = 96;
    /// Last byte of the TX buffer RAM window.
    pub const TX_RAM_LAST: u8 = 108;
}

/// BasicCAN register addresses (CDR.7 = 0).
pub mod basic {
    /// Control register.
    pub const CR: u8 = 0;
    /// Command register (write only).
    pub const CMR: u8 = 1;
    /// Status register.
    pub const SR: u8 = 2;
    /// Interrupt register.
    pub const IR: u8 = 3;
    /// Acceptance code register.
    pub const ACR: u8 = 4;
    /// Acceptance mask register.
    pub const AMR: u8 = 5;
    /// Bus timing register 0.
    pub const BTR0: u8 = 6;
    /// Bus timing register 1.
    pub const BTR1: u8 = 7;
    /// Output control register.
    pub const OCR: u8 = 8;
    /// First byte of the TX buffer (identifier bits 10..3).
    pub const TX: u8 = 10;
    /// Last byte of the TX buffer (data byte 8).
    pub const TX_LAST: u8 = 19;
    /// First byte of the RX buffer (identifier bits 10..3).
    pub const RX: u8 = 20;
    /// Second byte of the RX buffer: ID.2..0, RTR, DLC.
    pub const RX_ID_DLC: u8 = 21;
    /// Last byte of the RX buffer (data byte 8).
    pub const RX_LAST: u8 = 29;
    /// Clock divider register.
    pub const CDR: u8 = 31;
}

/// MOD bits (PeliCAN).
pub mod mode {
    /// Reset mode.
    pub const RM: u8 = 0x01;
    /// Listen-only mode.
    pub const LOM: u8 = 0x02;
    /// Self-test mode.
    pub const STM: u8 = 0x04;
    /// Acceptance filter mode: single filter.
    pub const AFM: u8 = 0x08;
    /// Sleep mode.
    pub const SM: u8 = 0x10;
}

/// BasicCAN control register bits.
pub mod control {
    /// Reset request.
    pub const RR: u8 = 0x01;
    /// Receive interrupt enable.
    pub const RIE: u8 = 0x02;
    /// Transmit interrupt enable.
    pub const TIE: u8 = 0x04;
    /// Error interrupt enable.
    pub const EIE: u8 = 0x08;
    /// Overrun interrupt enable.
    pub const OIE: u8 = 0x10;
    /// Reads as 1.
    pub const ALWAYS_ONE: u8 = 0x20;
}

/// CMR bits.
pub mod command {
    /// Transmission request.
    pub const TR: u8 = 0x01;
    /// Abort transmission.
    pub const AT: u8 = 0x02;
    /// Release receive buffer.
    pub const RRB: u8 = 0x04;
    /// Clear data overrun.
    pub const CDO: u8 = 0x08;
    /// Self-reception request (PeliCAN).
    pub const SRR: u8 = 0x10;
    /// Go to sleep (BasicCAN).
    pub const GTS: u8 = 0x10;
}

/// SR bits.
pub mod status {
    /// Receive buffer status: a message is stored.
    pub const RBS: u8 = 0x01;
    /// Data overrun status.
    pub const DOS: u8 = 0x02;
    /// Transmit buffer status: free.
    pub const TBS: u8 = 0x04;
    /// Transmission complete status.
    pub const TCS: u8 = 0x08;
    /// Receive status.
    pub const RS: u8 = 0x10;
    /// Transmit status.
    pub const TS: u8 = 0x20;
    /// Error status.
    pub const ES: u8 = 0x40;
    /// Bus status: bus-off.
    pub const BS: u8 = 0x80;
}

/// IR and IER bits (PeliCAN; BasicCAN uses bits 0..4 of IR).
pub mod interrupt {
    /// Receive interrupt.
    pub const RI: u8 = 0x01;
    /// Transmit interrupt.
    pub const TI: u8 = 0x02;
    /// Error warning interrupt.
    pub const EI: u8 = 0x04;
    /// Data overrun interrupt.
    pub const DOI: u8 = 0x08;
    /// Wake-up interrupt.
    pub const WUI: u8 = 0x10;
    /// Error passive interrupt.
    pub const EPI: u8 = 0x20;
    /// Arbitration lost interrupt.
    pub const ALI: u8 = 0x40;
    /// Bus error interrupt.
    pub const BEI: u8 = 0x80;
}

/// CDR bits.
pub mod clock_divider {
    /// CLKOUT divider code (bits 2..0).
    pub const DIVIDER: u8 = 0x07;
    /// Clock output off.
    pub const CLOCK_OFF: u8 = 0x08;
    /// RX interrupt output enable.
    pub const RXINTEN: u8 = 0x20;
    /// Comparator bypass.
    pub const CBP: u8 = 0x40;
    /// PeliCAN mode.
    pub const PELICAN: u8 = 0x80;
}

/// The frame-buffer layout (TX buffer and RX buffer, PeliCAN): byte indices inside a frame.
pub mod frame_buffer {
    /// Frame information: FF (7), RTR (6), DLC (3..0).
    pub const FRAME_INFO: u64 = 0;
    /// The first identifier byte (ID.28..21).
    pub const FIRST_ID_BYTE: u64 = 1;
    /// The first data byte of a standard frame (after 2 identifier bytes).
    pub const STANDARD_DATA_BYTE: u64 = 3;
    /// The first data byte of an extended frame (after 4 identifier bytes).
    pub const EXTENDED_DATA_BYTE: u64 = 5;
}

/// Error warning limit after a hardware reset.
pub const DEFAULT_EWLR: u8 = 96;
