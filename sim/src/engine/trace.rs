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
//! are written as bytes with each variable's change lines formatted once, each timestamp made from
//! the previous one by a decimal addition, and only the probes that changed are looked at bit by
//! bit (`fmt` per change cost a sixth of a traced run; these steps took tracing the compiled engine
//! from about 30 % to about 17 % of a run).

use std::fs::File;
use std::io::{self, BufWriter, Write};
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

/// A variable's change lines, `0<id>\n` then `1<id>\n`, formatted once.
struct Wire {
    lines: Box<[u8]>,
    len: usize,
}

impl Wire {
    fn new(id: IdCode) -> Wire {
        let lines = format!("0{id}\n1{id}\n").into_bytes().into_boxed_slice();
        Wire {
            len: lines.len() / 2,
            lines,
        }
    }

    /// The change line to `value`.
    fn line(&self, value: bool) -> &[u8] {
        let at = usize::from(value) * self.len;
        &self.lines[at..at + self.len]
    }
}

/// Writes the change line of `wire` to `value`: `0<id>` or `1<id>`.
fn change(out: &mut impl Write, wire: &Wire, value: bool) -> io::Result<()> {
    out.write_all(wire.line(value))
}

/// The current timestamp line, kept as text: the next one is the previous plus a small step
/// (one clock period, or less between two nodes' edges), added digit by digit from the right
/// instead of formatting the whole number again (a timestamp per traced edge made formatting
/// a third of the tracer's instructions).
struct TimestampLine {
    text: [u8; TIMESTAMP_MAX],
    len: usize,
    ns: u64,
}

impl TimestampLine {
    fn new(ns: u64) -> TimestampLine {
        let mut line = TimestampLine {
            text: [0; TIMESTAMP_MAX],
            len: 0,
            ns,
        };
        line.len = format_timestamp(&mut line.text, ns);
        line
    }

    /// The current line.
    fn text(&self) -> &[u8] {
        &self.text[..self.len]
    }

    /// Moves to `ns` (not earlier than the current time) and returns the line.
    fn advance(&mut self, ns: u64) -> &[u8] {
        let mut carry = ns - self.ns;
        self.ns = ns;
        // The digits sit between `#` and the newline.
        let mut at = self.len - 1;
        while carry != 0 {
            if at == 1 {
                // One digit more: format afresh.
                self.len = format_timestamp(&mut self.text, ns);
                return self.text();
            }
            at -= 1;
            let digit = u64::from(self.text[at] - b'0') + carry % 10;
            carry /= 10;
            if digit >= 10 {
                self.text[at] = b'0' + (digit - 10) as u8;
                carry += 1;
            } else {
                self.text[at] = b'0' + digit as u8;
            }
        }
        self.text()
    }
}

/// The longest timestamp line: `#`, 20 digits, newline.
const TIMESTAMP_MAX: usize = 22;

/// The decimal digits of 0..100, two per number.
const DIGIT_PAIRS: &[u8; 200] = b"\
    0001020304050607080910111213141516171819202122232425262728293031323334353637383940414243444546474849\
    5051525354555657585960616263646566676869707172737475767778798081828384858687888990919293949596979899";

/// Writes `#<ns>\n` at the start of `out` (at least [`TIMESTAMP_MAX`] bytes) and returns its
/// length; two digits per division (one line per traced edge).
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
    /// The file after the header.
    out: BufWriter<File>,
    target: PathBuf,
    temporary: PathBuf,
    bus: Wire,
    bus_last: bool,
    bus_probes: Vec<ProbeIds>,
    devices: Vec<DeviceTrace>,
    now: TimestampLine,
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
        let mut out = BufWriter::with_capacity(1 << 16, file);
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
        let now = TimestampLine::new(0);
        out.write_all(now.text())?;
        change(&mut out, &bus, true)?;
        for p in &bus_probes {
            for wire in &p.bits {
                change(&mut out, wire, false)?;
            }
        }
        for d in &traces {
            change(&mut out, &d.tx, true)?;
            change(&mut out, &d.rx, true)?;
            for p in &d.probes {
                for wire in &p.bits {
                    change(&mut out, wire, false)?;
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
            now,
            finished: false,
        })
    }

    fn at(&mut self, t_fs: u64) -> io::Result<()> {
        let ns = (t_fs + FS_PER_NS / 2) / FS_PER_NS;
        if ns != self.now.ns {
            self.out.write_all(self.now.advance(ns))?;
        }
        Ok(())
    }

    /// The bus level changes to `level` at `t_fs` (times never decrease across calls).
    pub fn bus(&mut self, t_fs: u64, value: bool) -> io::Result<()> {
        if value != self.bus_last {
            self.bus_last = value;
            self.at(t_fs)?;
            change(&mut self.out, &self.bus, value)?;
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
            change(&mut self.out, &d.tx, tx)?;
        }
        if d.rx_last != rx {
            d.rx_last = rx;
            change(&mut self.out, &d.rx, rx)?;
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
        if end_ns > self.now.ns {
            self.out.write_all(self.now.advance(end_ns))?;
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
fn write_probe(out: &mut impl Write, probe: &mut ProbeIds, value: u64) -> io::Result<()> {
    let mut diff = probe.last ^ value;
    probe.last = value;
    while diff != 0 {
        let bit = diff.trailing_zeros() as usize;
        diff &= diff - 1;
        change(out, &probe.bits[bit], value >> bit & 1 == 1)?;
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
            let mut out = [0u8; TIMESTAMP_MAX];
            let len = format_timestamp(&mut out, ns);
            assert_eq!(
                std::str::from_utf8(&out[..len]).unwrap(),
                format!("#{ns}\n")
            );
        }
    }

    #[test]
    fn a_timestamp_advanced_step_by_step_reads_as_the_number() {
        let mut line = TimestampLine::new(0);
        let mut ns = 0u64;
        for step in [
            0,
            1,
            8,
            1,
            89,
            900,
            31,
            32,
            9_000_000,
            1,
            99_999,
            123_456_789_012,
            7,
        ] {
            ns += step;
            let text = line.advance(ns).to_vec();
            assert_eq!(
                String::from_utf8(text).unwrap(),
                format!("#{ns}\n"),
                "after {step}"
            );
        }
        let mut line = TimestampLine::new(u64::MAX - 3);
        assert_eq!(
            line.advance(u64::MAX),
            format!("#{}\n", u64::MAX).as_bytes()
        );
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
