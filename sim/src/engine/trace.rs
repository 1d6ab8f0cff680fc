//! Selective VCD tracer (the `vcd` crate, not rust-hdl's whole-tree probe).
//!
//! Layout: a top scope with the 1-bit wire `bus` and any signals derived from it (the number of the
//! frame on the bus), then one scope per device with `tx`, `rx` and the
//! device's own probes. Every variable is a 1-bit wire, so protocol decoders such as sigrok's CAN decoder
//! (which abort on vector variables) read the file; a probe wider than one bit is written as bit-select
//! wires `name [i]`, which the GTKWave views in `waves/` regroup into vectors. Timescale 1 ns. A
//! header comment records the bus's bit timing when the caller knows it, so that `cansim decode` and
//! the agreement checks decode the file without being told. Output is buffered and goes to a
//! temporary file that replaces the target only when [`VcdTracer::finish`] succeeds, so an aborted run
//! never leaves a half-written VCD behind (a tracer dropped without finishing removes its temporary
//! file). The `vcd` crate writes the header; value changes, one or more per simulated clock edge,
//! are written as bytes with each variable's change lines formatted once and copied into the
//! buffer as fixed 8-byte words, timestamps two digits per division, and only the probes that
//! changed are looked at bit by bit (`fmt` per change cost a sixth of a traced run; these steps
//! took tracing the compiled engine from about 30 % to about 18 % of a run).

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use vcd::{IdCode, ReferenceIndex, TimescaleUnit, VarType};

use crate::engine::bus_timing::timing_comment;
use crate::engine::bus_timing::BusTiming;
use crate::engine::time::FS_PER_NS;

/// A device signal to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Probe {
    /// Name inside the device's scope.
    pub name: &'static str,
    /// Width in bits (1..=64).
    pub width: u32,
}

impl Probe {
    /// A 1-bit probe.
    pub const fn bit(name: &'static str) -> Probe {
        Probe { name, width: 1 }
    }
}

/// The longest identifier a change line holds in its fixed 8 bytes (with the value and newline).
const MAX_ID: usize = 6;

/// A variable's change lines, `0<id>\n` and `1<id>\n`, formatted once in 8 bytes each so that they
/// enter the output by a fixed-size copy.
struct Wire {
    lines: [[u8; 8]; 2],
    len: usize,
}

impl Wire {
    fn new(id: IdCode) -> Wire {
        let id = id.to_string();
        assert!(
            id.len() <= MAX_ID,
            "VCD identifier {id} longer than {MAX_ID}"
        );
        let mut lines = [[0u8; 8]; 2];
        for (value, line) in lines.iter_mut().enumerate() {
            line[0] = b'0' + value as u8;
            line[1..=id.len()].copy_from_slice(id.as_bytes());
            line[id.len() + 1] = b'\n';
        }
        Wire {
            lines,
            len: id.len() + 2,
        }
    }

    /// The change line to `value`.
    #[cfg(test)]
    fn line(&self, value: bool) -> &[u8] {
        &self.lines[usize::from(value)][..self.len]
    }
}

/// The buffer is written to the file when it holds this many bytes.
const FLUSH_AT: usize = 1 << 16;
/// Room after `FLUSH_AT` for the fixed-size copies of one line.
const SLACK: usize = 32;

/// The file after the header, through a buffer that change lines and timestamps enter without a
/// call per line (they are written at every traced clock edge).
struct Output {
    file: File,
    buf: Box<[u8]>,
    len: usize,
}

impl Output {
    fn new(file: File) -> Output {
        Output {
            file,
            buf: vec![0; FLUSH_AT + SLACK].into_boxed_slice(),
            len: 0,
        }
    }

    fn after_put(&mut self) -> io::Result<()> {
        if self.len >= FLUSH_AT {
            self.write_buffer()?;
        }
        Ok(())
    }

    fn write_buffer(&mut self) -> io::Result<()> {
        self.file.write_all(&self.buf[..self.len])?;
        self.len = 0;
        Ok(())
    }

    /// Writes the change line of `wire` to `value`: `0<id>` or `1<id>`.
    fn change(&mut self, wire: &Wire, value: bool) -> io::Result<()> {
        self.buf[self.len..self.len + 8].copy_from_slice(&wire.lines[usize::from(value)]);
        self.len += wire.len;
        self.after_put()
    }

    /// Writes the timestamp line `#<ns>`.
    fn timestamp(&mut self, ns: u64) -> io::Result<()> {
        self.len += format_timestamp(&mut self.buf[self.len..self.len + SLACK], ns);
        self.after_put()
    }
}

impl Write for Output {
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        if self.len + data.len() > FLUSH_AT {
            self.write_buffer()?;
        }
        if data.len() > FLUSH_AT {
            return self.file.write(data);
        }
        self.buf[self.len..self.len + data.len()].copy_from_slice(data);
        self.len += data.len();
        Ok(data.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.write_buffer()?;
        self.file.flush()
    }
}

/// The decimal digits of 0..100, two per number.
const DIGIT_PAIRS: &[u8; 200] = b"\
    0001020304050607080910111213141516171819202122232425262728293031323334353637383940414243444546474849\
    5051525354555657585960616263646566676869707172737475767778798081828384858687888990919293949596979899";

/// Writes `#<ns>\n` at the start of `out` (at least 22 bytes) and returns its length; two digits
/// per division.
fn format_timestamp(out: &mut [u8], ns: u64) -> usize {
    let digits = ns.checked_ilog10().unwrap_or(0) as usize + 1;
    out[0] = b'#';
    let mut at = digits + 1;
    out[at] = b'\n';
    let mut rest = ns;
    while rest >= 100 {
        let pair = (rest % 100) as usize * 2;
        rest /= 100;
        at -= 2;
        out[at..at + 2].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
    }
    if rest >= 10 {
        let pair = rest as usize * 2;
        out[at - 2..at].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
    } else {
        out[at - 1] = b'0' + rest as u8;
    }
    digits + 2
}

struct ProbeIds {
    /// One wire per bit, bit 0 first.
    bits: Vec<Wire>,
    last: u64,
}

struct DeviceTrace {
    tx: Wire,
    rx: Wire,
    tx_last: bool,
    rx_last: bool,
    probes: Vec<ProbeIds>,
}

/// Writes the bus and per-device signals of one simulation run as a VCD file.
pub struct VcdTracer {
    out: Output,
    target: PathBuf,
    temporary: PathBuf,
    bus: Wire,
    bus_last: bool,
    bus_probes: Vec<ProbeIds>,
    devices: Vec<DeviceTrace>,
    now_ns: u64,
    finished: bool,
}

impl VcdTracer {
    /// Creates the tracer for `bus_probes` (signals beside `bus` in the top scope) and `devices`
    /// (scope name and probes of each), writing to `path`; `timing`, the bus's bit timing if known,
    /// is recorded in a header comment ([`timing_comment`]) for decoders.
    pub fn create(
        path: &Path,
        bus_probes: &[Probe],
        devices: &[(String, Vec<Probe>)],
        timing: Option<&BusTiming>,
    ) -> io::Result<VcdTracer> {
        let temporary = path.with_extension("vcd.partial");
        let file = File::create(&temporary).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("cannot create {}: {e}", temporary.display()),
            )
        })?;
        let mut out = Output::new(file);
        let mut writer = vcd::Writer::new(&mut out);
        writer.comment(concat!("written by cansim ", env!("CARGO_PKG_VERSION")))?;
        if let Some(timing) = timing {
            writer.comment(&timing_comment(timing))?;
        }
        writer.timescale(1, TimescaleUnit::NS)?;
        writer.add_module("top")?;
        let bus = Wire::new(writer.add_wire(1, "bus")?);
        let bus_probes = bus_probes
            .iter()
            .map(|p| add_probe(&mut writer, p))
            .collect::<io::Result<Vec<_>>>()?;
        writer.upscope()?;
        let mut traces = Vec::new();
        for (name, probes) in devices {
            writer.add_module(name)?;
            let tx = Wire::new(writer.add_wire(1, "tx")?);
            let rx = Wire::new(writer.add_wire(1, "rx")?);
            let ids = probes
                .iter()
                .map(|p| add_probe(&mut writer, p))
                .collect::<io::Result<Vec<_>>>()?;
            writer.upscope()?;
            traces.push(DeviceTrace {
                tx,
                rx,
                tx_last: true,
                rx_last: true,
                probes: ids,
            });
        }
        writer.enddefinitions()?;
        out.timestamp(0)?;
        out.change(&bus, true)?;
        for p in &bus_probes {
            for wire in &p.bits {
                out.change(wire, false)?;
            }
        }
        for d in &traces {
            out.change(&d.tx, true)?;
            out.change(&d.rx, true)?;
            for p in &d.probes {
                for wire in &p.bits {
                    out.change(wire, false)?;
                }
            }
        }
        Ok(VcdTracer {
            out,
            target: path.to_path_buf(),
            temporary,
            bus,
            bus_last: true,
            bus_probes,
            devices: traces,
            now_ns: 0,
            finished: false,
        })
    }

    fn at(&mut self, t_fs: u64) -> io::Result<()> {
        let ns = (t_fs + FS_PER_NS / 2) / FS_PER_NS;
        if ns != self.now_ns {
            self.now_ns = ns;
            self.out.timestamp(ns)?;
        }
        Ok(())
    }

    /// The bus level changes to `level` at `t_fs` (times never decrease across calls).
    pub fn bus(&mut self, t_fs: u64, value: bool) -> io::Result<()> {
        if value != self.bus_last {
            self.bus_last = value;
            self.at(t_fs)?;
            self.out.change(&self.bus, value)?;
        }
        Ok(())
    }

    /// Device `index` after its clock edge at `t_fs`: its drive level, the rx level it sampled, and its
    /// probe values in the order given to [`VcdTracer::create`].
    pub fn device(
        &mut self,
        index: usize,
        t_fs: u64,
        tx: bool,
        rx: bool,
        values: &[u64],
    ) -> io::Result<()> {
        let d = &self.devices[index];
        let changed = d.tx_last != tx
            || d.rx_last != rx
            || d.probes.iter().zip(values).any(|(p, v)| p.last != *v);
        if !changed {
            return Ok(());
        }
        self.at(t_fs)?;
        let d = &mut self.devices[index];
        if d.tx_last != tx {
            d.tx_last = tx;
            self.out.change(&d.tx, tx)?;
        }
        if d.rx_last != rx {
            d.rx_last = rx;
            self.out.change(&d.rx, rx)?;
        }
        for (p, &v) in d.probes.iter_mut().zip(values) {
            if p.last != v {
                write_probe(&mut self.out, p, v)?;
            }
        }
        Ok(())
    }

    /// Bus probe `index` (in the order given to [`VcdTracer::create`]) changes to `value` at
    /// `t_fs` (times never decrease across calls).
    pub fn bus_probe(&mut self, index: usize, t_fs: u64, value: u64) -> io::Result<()> {
        if self.bus_probes[index].last == value {
            return Ok(());
        }
        self.at(t_fs)?;
        write_probe(&mut self.out, &mut self.bus_probes[index], value)
    }

    /// Writes the final timestamp, flushes, and moves the file into place.
    pub fn finish(mut self, t_end_fs: u64) -> io::Result<PathBuf> {
        let end_ns = (t_end_fs + FS_PER_NS / 2) / FS_PER_NS;
        if end_ns > self.now_ns {
            self.out.timestamp(end_ns)?;
        }
        self.out.flush()?;
        std::fs::rename(&self.temporary, &self.target).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("cannot write {}: {e}", self.target.display()),
            )
        })?;
        self.finished = true;
        Ok(self.target.clone())
    }
}

/// Declares `probe`'s wires: one, or one bit-select wire per bit.
fn add_probe(writer: &mut vcd::Writer<impl Write>, probe: &Probe) -> io::Result<ProbeIds> {
    assert!(
        (1..=64).contains(&probe.width),
        "probe {} has width {}",
        probe.name,
        probe.width
    );
    let bits = if probe.width == 1 {
        vec![Wire::new(writer.add_wire(1, probe.name)?)]
    } else {
        (0..probe.width)
            .map(|i| {
                let index = Some(ReferenceIndex::BitSelect(i as i32));
                writer
                    .add_var(VarType::Wire, 1, probe.name, index)
                    .map(Wire::new)
            })
            .collect::<io::Result<Vec<_>>>()?
    };
    Ok(ProbeIds { bits, last: 0 })
}

/// Writes the wires of `probe` whose bit differs in `value`.
fn write_probe(out: &mut Output, probe: &mut ProbeIds, value: u64) -> io::Result<()> {
    let mut diff = probe.last ^ value;
    probe.last = value;
    while diff != 0 {
        let bit = diff.trailing_zeros() as usize;
        diff &= diff - 1;
        out.change(&probe.bits[bit], value >> bit & 1 == 1)?;
    }
    Ok(())
}

impl Drop for VcdTracer {
    fn drop(&mut self) {
        if !self.finished {
            // An unfinished trace is useless; nobody can report a failure to remove it.
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_are_written_in_decimal_whatever_their_number_of_digits() {
        for ns in [0, 7, 10, 99, 100, 101, 12_345, 1_000_000, u64::MAX] {
            let mut out = [0u8; SLACK];
            let len = format_timestamp(&mut out, ns);
            assert_eq!(
                std::str::from_utf8(&out[..len]).unwrap(),
                format!("#{ns}\n")
            );
        }
    }

    #[test]
    fn a_change_line_is_the_value_then_the_identifier() {
        for number in [0u32, 93, 94, 10_000] {
            let wire = Wire::new(IdCode::from(number));
            let id = IdCode::from(number).to_string();
            assert_eq!(wire.line(false), format!("0{id}\n").as_bytes());
            assert_eq!(wire.line(true), format!("1{id}\n").as_bytes());
        }
    }
}
