//! Bus master models for the wrapper benches (`crate::wrapper_equivalence`): each runs a list of
//! [`BusOp`]s through one wrapper's bus protocol, closed loop (it waits for the wrapper's ready or
//! acknowledge), and keeps what the reads gave. They play the SoC side: Wishbone classic and
//! pipelined, AXI4-Lite with independent channel delays and ready back-pressure, APB with its setup
//! and access phases.

use crate::wrapper_equivalence::Master;

/// One operation of a master.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusOp {
    /// A write of `data` at byte address `addr` with these byte-lane strobes.
    Write {
        /// Byte address.
        addr: u32,
        /// 32-bit data (lane k in bits 8k+7..8k).
        data: u32,
        /// Lanes written.
        strobe: u8,
    },
    /// A read at byte address `addr` (Wishbone: of the lanes `strobe` selects).
    Read {
        /// Byte address.
        addr: u32,
        /// Lanes selected (Wishbone's `sel`; AXI and APB read the lane `addr` names).
        strobe: u8,
    },
    /// A write and a read issued together (AXI4-Lite; the others do them one after the other).
    WriteRead {
        /// The write's byte address, data and strobes.
        write: (u32, u32, u8),
        /// The read's byte address.
        read: u32,
    },
    /// Nothing for this many cycles.
    Idle(usize),
    /// The wrapper's reset for this many cycles (in the middle of whatever it was doing).
    Reset(usize),
}

/// The SJA1000 register accesses of a script as bus operations for a register layout.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// One register per 32-bit word (`reg-io-width = 4`) instead of bytes at byte addresses.
    pub word_stride: bool,
}

impl Layout {
    /// A byte write of register `reg`.
    pub fn write(self, reg: u8, value: u8) -> BusOp {
        let (addr, lane) = self.place(reg);
        BusOp::Write {
            addr,
            data: u32::from(value) << (8 * lane),
            strobe: 1 << lane,
        }
    }

    /// A byte read of register `reg`.
    pub fn read(self, reg: u8) -> BusOp {
        let (addr, lane) = self.place(reg);
        BusOp::Read {
            addr,
            strobe: 1 << lane,
        }
    }

    /// The byte address and byte lane of register `reg`.
    pub fn place(self, reg: u8) -> (u32, u32) {
        if self.word_stride {
            (4 * u32::from(reg), 0)
        } else {
            (u32::from(reg), u32::from(reg) % 4)
        }
    }

    /// Which of a read's 32 bits hold register `reg`.
    pub fn byte_of(self, reg: u8, word: u32) -> u8 {
        (word >> (8 * self.place(reg).1)) as u8
    }
}

/// Steps through a list of operations; the bus-specific part says when one is done.
struct Script {
    ops: Vec<BusOp>,
    at: usize,
    /// Cycles spent in the current operation.
    cycle: usize,
    reads: Vec<u32>,
}

impl Script {
    fn new(ops: Vec<BusOp>) -> Script {
        Script {
            ops,
            at: 0,
            cycle: 0,
            reads: Vec::new(),
        }
    }

    fn current(&self) -> Option<BusOp> {
        self.ops.get(self.at).copied()
    }

    fn next(&mut self) {
        self.at += 1;
        self.cycle = 0;
    }

    /// Idle and reset operations: whether this cycle is one of theirs (and the reset level).
    fn timed(&mut self) -> Option<bool> {
        let (n, reset) = match self.current()? {
            BusOp::Idle(n) => (n, false),
            BusOp::Reset(n) => (n, true),
            _ => return None,
        };
        self.cycle += 1;
        if self.cycle >= n {
            self.next();
        }
        Some(reset)
    }
}

/// A Wishbone B4 master: classic cycles (`stb` held until `ack`), or pipelined (`stb` for the cycle
/// the request is taken, `cyc` until `ack`).
pub struct WishboneMaster {
    script: Script,
    pipelined: bool,
    /// The request was taken (pipelined).
    taken: bool,
    /// The `ack` of the current operation was seen: it ends with this cycle.
    ending: bool,
}

impl WishboneMaster {
    /// A master running `ops`.
    pub fn new(ops: Vec<BusOp>, pipelined: bool) -> WishboneMaster {
        WishboneMaster {
            script: Script::new(split_write_reads(ops)),
            pipelined,
            taken: false,
            ending: false,
        }
    }
}

/// `WriteRead` as a write, then a read (for the buses that do one thing at a time).
fn split_write_reads(ops: Vec<BusOp>) -> Vec<BusOp> {
    ops.into_iter()
        .flat_map(|op| match op {
            BusOp::WriteRead {
                write: (addr, data, strobe),
                read,
            } => vec![
                BusOp::Write { addr, data, strobe },
                BusOp::Read {
                    addr: read,
                    strobe: 1 << (read % 4),
                },
            ],
            op => vec![op],
        })
        .collect()
}

impl Master for WishboneMaster {
    // Inputs: reset, cyc, stb, we, adr, sel, dat_w. Outputs: dat_r, ack, stall, tx, irq, clkout.
    fn drive(&mut self, out: &[u64]) -> Vec<u64> {
        if self.ending {
            self.ending = false;
            self.taken = false;
            self.script.next();
        }
        if let Some(reset) = self.script.timed() {
            return vec![u64::from(reset), 0, 0, 0, 0, 0, 0];
        }
        let (we, addr, data, sel) = match self.script.current() {
            Some(BusOp::Write { addr, data, strobe }) => (1, addr, data, strobe),
            Some(BusOp::Read { addr, strobe }) => (0, addr, 0, strobe),
            _ => return vec![0; 7],
        };
        if self.script.cycle > 0 && out[1] == 1 {
            if we == 0 {
                self.script.reads.push(out[0] as u32);
            }
            self.ending = true;
        }
        let stb = !(self.pipelined && self.taken);
        // Pipelined: the request is taken at the edge that sees it without a stall.
        if self.pipelined && stb && out[2] == 0 {
            self.taken = true;
        }
        self.script.cycle += 1;
        vec![
            0,
            1,
            u64::from(stb),
            we,
            u64::from(addr >> 2),
            u64::from(sel),
            u64::from(data),
        ]
    }

    fn finished(&self) -> bool {
        self.script.current().is_none()
    }

    fn reads(&self) -> &[u32] {
        &self.script.reads
    }
}

/// An AXI4-Lite master: write address and write data each after their own delay (so either may
/// come first), `bready` and `rready` held back for a while, a write and a read at once with
/// `WriteRead`.
pub struct AxiLiteMaster {
    script: Script,
    /// Channel delays of the current operation, in cycles: AW, W, B ready, AR, R ready.
    delays: [usize; 5],
    /// Handshakes done: AW, W, B, AR, R.
    done: [bool; 5],
}

impl AxiLiteMaster {
    /// A master running `ops`.
    pub fn new(ops: Vec<BusOp>) -> AxiLiteMaster {
        AxiLiteMaster {
            script: Script::new(ops),
            delays: [0; 5],
            done: [false; 5],
        }
    }

    /// The delays of operation `k`: a fixed pattern that puts AW before W, W before AW and both
    /// together, and ready back-pressure of 0 to 2 cycles.
    fn delays_of(k: usize) -> [usize; 5] {
        [[0, 0, 0, 0, 0], [2, 0, 1, 1, 2], [0, 3, 2, 0, 0]][k % 3]
    }
}

impl Master for AxiLiteMaster {
    // Inputs: reset, awvalid, awaddr, wvalid, wdata, wstrb, bready, arvalid, araddr, rready.
    // Outputs: awready, wready, bvalid, bresp, arready, rvalid, rdata, rresp, tx, irq, clkout.
    fn drive(&mut self, out: &[u64]) -> Vec<u64> {
        if let Some(reset) = self.script.timed() {
            self.done = [false; 5];
            return vec![u64::from(reset), 0, 0, 0, 0, 0, 0, 0, 0, 0];
        }
        let (write, read) = match self.script.current() {
            Some(BusOp::Write { addr, data, strobe }) => (Some((addr, data, strobe)), None),
            Some(BusOp::Read { addr, .. }) => (None, Some(addr)),
            Some(BusOp::WriteRead { write, read }) => (Some(write), Some(read)),
            _ => return vec![0; 10],
        };
        if self.script.cycle == 0 {
            self.delays = AxiLiteMaster::delays_of(self.script.at);
            self.done = [
                write.is_none(),
                write.is_none(),
                write.is_none(),
                read.is_none(),
                read.is_none(),
            ];
        }
        let c = self.script.cycle;
        let (aw, w, b, ar, r) = (0, 1, 2, 3, 4);
        // The readies come from flip-flops: what the wrapper shows now holds for the coming edge.
        let awvalid = !self.done[aw] && c >= self.delays[aw];
        let wvalid = !self.done[w] && c >= self.delays[w];
        let bready = !self.done[b] && self.done[aw] && self.done[w] && c >= self.delays[b];
        let arvalid = !self.done[ar] && c >= self.delays[ar];
        let rready = !self.done[r] && self.done[ar] && c >= self.delays[r];
        // Handshakes at the coming edge: valid and ready both high in this cycle.
        if awvalid && out[0] == 1 {
            self.done[aw] = true;
        }
        if wvalid && out[1] == 1 {
            self.done[w] = true;
        }
        if bready && out[2] == 1 {
            self.done[b] = true;
        }
        if arvalid && out[4] == 1 {
            self.done[ar] = true;
        }
        if rready && out[5] == 1 {
            self.done[r] = true;
            self.script.reads.push(out[6] as u32);
        }
        self.script.cycle += 1;
        let (waddr, wdata, wstrb) = write.unwrap_or((0, 0, 0));
        let inputs = vec![
            0,
            u64::from(awvalid),
            u64::from(waddr),
            u64::from(wvalid),
            u64::from(wdata),
            u64::from(wstrb),
            u64::from(bready),
            u64::from(arvalid),
            u64::from(read.unwrap_or(0)),
            u64::from(rready),
        ];
        if self.done.iter().all(|d| *d) {
            self.script.next();
        }
        inputs
    }

    fn finished(&self) -> bool {
        self.script.current().is_none()
    }

    fn reads(&self) -> &[u32] {
        &self.script.reads
    }
}

/// An APB master: a setup phase, then the access phase until `pready`; APB4 strobes.
pub struct ApbMaster {
    script: Script,
    ending: bool,
}

impl ApbMaster {
    /// A master running `ops`.
    pub fn new(ops: Vec<BusOp>) -> ApbMaster {
        ApbMaster {
            script: Script::new(split_write_reads(ops)),
            ending: false,
        }
    }
}

impl Master for ApbMaster {
    // Inputs: reset, psel, penable, pwrite, paddr, pwdata, pstrb. Outputs: prdata, pready,
    // pslverr, tx, irq, clkout.
    fn drive(&mut self, out: &[u64]) -> Vec<u64> {
        if self.ending {
            self.ending = false;
            self.script.next();
        }
        if let Some(reset) = self.script.timed() {
            return vec![u64::from(reset), 0, 0, 0, 0, 0, 0];
        }
        let (write, addr, data, strobe) = match self.script.current() {
            Some(BusOp::Write { addr, data, strobe }) => (1, addr, data, strobe),
            Some(BusOp::Read { addr, .. }) => (0, addr, 0, 0),
            _ => return vec![0; 7],
        };
        let access = self.script.cycle > 0;
        if self.script.cycle > 1 && out[1] == 1 {
            if write == 0 {
                self.script.reads.push(out[0] as u32);
            }
            self.ending = true;
        }
        self.script.cycle += 1;
        vec![
            0,
            1,
            u64::from(access),
            write,
            u64::from(addr),
            u64::from(data),
            u64::from(strobe),
        ]
    }

    fn finished(&self) -> bool {
        self.script.current().is_none()
    }

    fn reads(&self) -> &[u32] {
        &self.script.reads
    }
}
