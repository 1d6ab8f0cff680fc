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
//! the previous one by a decimal addition, and a device's `tx`, `rx` and probes packed into words,
//! so that an edge compares words and writes the lines of the bits that changed (`fmt` per change
//! cost a sixth of a traced run; these steps took tracing the compiled engine from about 30 % to
//! 11-14 % of a run, docs/ENGINES.md).

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

/// The longest change line: the value, an identifier (at most 5 characters for the `vcd`
/// crate's 32-bit codes), the newline; padded to a fixed size.
const LINE_MAX: usize = 8;

/// A variable's change lines, `0<id>\n` then `1<id>\n`, formatted once and padded to
/// [`LINE_MAX`] bytes, so writing one is a single fixed-size move.
#[derive(Clone, Copy)]
struct Wire {
    lines: [[u8; LINE_MAX]; 2],
    len: usize,
}

impl Wire {
    fn new(id: IdCode) -> Wire {
        let id = id.to_string();
        let len = id.len() + 2;
        assert!(len <= LINE_MAX, "VCD identifier {id} is too long");
        let mut lines = [[0; LINE_MAX]; 2];
        for (value, line) in lines.iter_mut().enumerate() {
            line[0] = b'0' + value as u8;
            line[1..len - 1].copy_from_slice(id.as_bytes());
            line[len - 1] = b'\n';
        }
        Wire { lines, len }
    }

    /// The change line to `value`.
    #[cfg(test)]
    fn line(&self, value: bool) -> &[u8] {
        &self.lines[usize::from(value)][..self.len]
    }
}

/// The file's buffer: change lines and timestamps are copied in as fixed-size blocks (a call to
/// `memcpy` and `BufWriter`'s checks per line were a third of the tracer's instructions).
struct Output {
    file: File,
    buf: Box<[u8]>,
    len: usize,
}

/// Bytes buffered before a write to the file.
const OUTPUT_CAPACITY: usize = 1 << 16;

impl Output {
    fn new(file: File) -> Output {
        Output {
            file,
            buf: vec![0; OUTPUT_CAPACITY].into_boxed_slice(),
            len: 0,
        }
    }

    /// Appends the first `len` bytes of `block`.
    #[inline]
    fn put<const N: usize>(&mut self, block: &[u8; N], len: usize) -> io::Result<()> {
        if self.len + N > self.buf.len() {
            self.flush()?;
        }
        self.buf[self.len..self.len + N].copy_from_slice(block);
        self.len += len;
        Ok(())
    }

    /// Writes the change line of `wire` to `value`: `0<id>` or `1<id>`.
    #[inline]
    fn change(&mut self, wire: &Wire, value: bool) -> io::Result<()> {
        self.put(&wire.lines[usize::from(value)], wire.len)
    }

    /// Appends the timestamp line `line`.
    fn timestamp(&mut self, line: &TimestampLine) -> io::Result<()> {
        self.put(&line.text, line.len)
    }

    /// Moves `line` to `ns` and appends it. The line is copied before it changes and changed in
    /// both places: copying bytes just stored one by one stalls the processor (a wide load
    /// cannot take them from the pending stores), which made the copy a third of the tracer's
    /// time.
    #[inline]
    fn advance_timestamp(&mut self, line: &mut TimestampLine, ns: u64) -> io::Result<()> {
        if self.len + TIMESTAMP_MAX > self.buf.len() {
            self.flush()?;
        }
        let copy: &mut [u8; TIMESTAMP_MAX] = (&mut self.buf[self.len..self.len + TIMESTAMP_MAX])
            .try_into()
            .expect("a timestamp's room");
        *copy = line.text;
        line.advance(ns, copy);
        self.len += line.len;
        Ok(())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.write_all(&self.buf[..self.len])?;
        self.len = 0;
        Ok(())
    }
}

/// The current timestamp line, kept as text: the next one is the previous plus a small step
/// (one clock period, or less between two nodes' edges), added digit by digit from the right
/// instead of formatting the whole number again (a timestamp per traced edge made formatting
/// a third of the tracer's instructions).
struct TimestampLine {
    text: [u8; TIMESTAMP_MAX],
    len: usize,
    ns: u64,
    /// `ns % 100`, the number its last two digits show.
    low: u64,
}

impl TimestampLine {
    fn new(ns: u64) -> TimestampLine {
        let mut line = TimestampLine {
            text: [0; TIMESTAMP_MAX],
            len: 0,
            ns,
            low: ns % 100,
        };
        line.len = format_timestamp(&mut line.text, ns);
        line
    }

    /// The current line.
    #[cfg(test)]
    fn text(&self) -> &[u8] {
        &self.text[..self.len]
    }

    /// Moves to `ns` (not earlier than the current time), making the same change in `copy`, a
    /// copy of the line before the move (see [`Output::timestamp`]).
    #[inline]
    fn advance(&mut self, ns: u64, copy: &mut [u8; TIMESTAMP_MAX]) {
        let step = ns - self.ns;
        self.ns = ns;
        // Steps are mostly below 100 ns: the last two digits at once from a table, then at most
        // a carry.
        if step < 100 && self.len >= 4 {
            let mut sum = self.low + step;
            let carry = sum >= 100;
            if carry {
                sum -= 100;
            }
            self.low = sum;
            let end = self.len - 1;
            let pair = &DIGIT_PAIRS[sum as usize * 2..sum as usize * 2 + 2];
            self.text[end - 2..end].copy_from_slice(pair);
            copy[end - 2..end].copy_from_slice(pair);
            if carry {
                self.add(copy, end - 2, 1);
            }
        } else {
            self.low = ns % 100;
            self.add(copy, self.len - 1, step);
        }
    }

    fn set_digit(&mut self, copy: &mut [u8; TIMESTAMP_MAX], at: usize, digit: u64) {
        let character = b'0' + digit as u8;
        self.text[at] = character;
        copy[at] = character;
    }

    /// Adds `carry` to the number formed by the digits before `end`.
    fn add(&mut self, copy: &mut [u8; TIMESTAMP_MAX], end: usize, mut carry: u64) {
        let mut at = end;
        while carry != 0 {
            if at == 1 {
                // One digit more: format afresh.
                self.len = format_timestamp(&mut self.text, self.ns);
                *copy = self.text;
                return;
            }
            at -= 1;
            let digit = u64::from(self.text[at] - b'0') + carry % 10;
            carry /= 10;
            if digit >= 10 {
                self.set_digit(copy, at, digit - 10);
                carry += 1;
            } else {
                self.set_digit(copy, at, digit);
            }
        }
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

/// The wires of a signal derived from the bus, one per bit, bit 0 first, and its last value.
struct ProbeIds {
    bits: Vec<Wire>,
    last: u64,
}

/// Where a device probe's bits go in the device's packed words.
#[derive(Clone, Copy)]
struct Place {
    word: usize,
    shift: u32,
    mask: u64,
}

/// A device's traced signals packed into 64-bit words (`tx` bit 0 and `rx` bit 1 of word 0,
/// then the probes, none across a word boundary), so that an edge compares and writes words
/// instead of visiting every probe.
struct DeviceTrace {
    /// The scope name, for errors.
    name: String,
    /// The wire of each bit of each word (a word's unused bits have unused wires).
    wires: Vec<Wire>,
    places: Vec<Place>,
    last: Vec<u64>,
    next: Vec<u64>,
}

impl DeviceTrace {
    fn new(
        writer: &mut vcd::Writer<impl Write>,
        name: &str,
        probes: &[Probe],
    ) -> io::Result<DeviceTrace> {
        let mut wires = vec![
            Wire::new(writer.add_wire(1, "tx")?),
            Wire::new(writer.add_wire(1, "rx")?),
        ];
        let mut places = Vec::with_capacity(probes.len());
        for probe in probes {
            let probe_wires = add_probe(writer, probe)?.bits;
            let used = wires.len() % 64;
            if used + probe_wires.len() > 64 {
                wires.resize(wires.len() + 64 - used, Wire::new(IdCode::from(0u32)));
            }
            places.push(Place {
                word: wires.len() / 64,
                shift: (wires.len() % 64) as u32,
                mask: u64::MAX >> (64 - probe.width),
            });
            wires.extend(probe_wires);
        }
        let words = wires.len().div_ceil(64);
        let mut last = vec![0; words];
        last[0] = 0b11;
        Ok(DeviceTrace {
            name: name.to_string(),
            wires,
            places,
            next: last.clone(),
            last,
        })
    }

    /// Word `word` is `next` from `t_fs` on: the lines of the bits that changed, after the
    /// timestamp if it is a new one. Inlined by force: it runs at every traced edge, and as a
    /// call it cost 4 % of the tracer's instructions.
    #[inline(always)]
    fn write_word(
        &mut self,
        out: &mut Output,
        now: &mut TimestampLine,
        word: usize,
        t_fs: u64,
        next: u64,
    ) -> io::Result<()> {
        let last = std::mem::replace(&mut self.last[word], next);
        if last == next {
            return Ok(());
        }
        at(out, now, t_fs)?;
        write_bits(out, &self.wires[word * 64..], last ^ next, next)
    }

    /// The initial values: `tx` and `rx` recessive, the probes 0.
    fn write_initial(&self, out: &mut Output) -> io::Result<()> {
        for (bit, wire) in self.wires.iter().enumerate() {
            if bit < 2 || self.places.iter().any(|p| p.covers(bit)) {
                out.change(wire, bit < 2)?;
            }
        }
        Ok(())
    }
}

impl Place {
    /// Whether the device's bit number `bit` belongs to this probe.
    fn covers(&self, bit: usize) -> bool {
        let start = self.word * 64 + self.shift as usize;
        (start..start + self.mask.count_ones() as usize).contains(&bit)
    }
}

/// Writes the bus and per-device signals of one simulation run as a VCD file.
pub struct VcdTracer {
    /// The file after the header.
    out: Output,
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
        let mut out = Output::new(file);
        let mut header = Vec::new();
        let mut writer = vcd::Writer::new(&mut header);
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
            traces.push(DeviceTrace::new(&mut writer, name, probes)?);
            writer.upscope()?;
        }
        writer.enddefinitions()?;
        out.file.write_all(&header)?;
        let now = TimestampLine::new(0);
        out.timestamp(&now)?;
        out.change(&bus, true)?;
        for p in &bus_probes {
            for wire in &p.bits {
                out.change(wire, false)?;
            }
        }
        for d in &traces {
            d.write_initial(&mut out)?;
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

    /// The bus level changes to `level` at `t_fs` (times never decrease across calls).
    pub fn bus(&mut self, t_fs: u64, value: bool) -> io::Result<()> {
        if value != self.bus_last {
            self.bus_last = value;
            at(&mut self.out, &mut self.now, t_fs)?;
            self.out.change(&self.bus, value)?;
        }
        Ok(())
    }

    /// Device `index` after its clock edge at `t_fs`: its drive level, the rx level it sampled, and its
    /// probe values in the order given to [`VcdTracer::create`] (bits beyond a probe's width are
    /// ignored).
    pub fn device(
        &mut self,
        index: usize,
        t_fs: u64,
        tx: bool,
        rx: bool,
        values: &[u64],
    ) -> io::Result<()> {
        let d = &mut self.devices[index];
        d.next.fill(0);
        d.next[0] = u64::from(tx) | u64::from(rx) << 1;
        for (place, &value) in d.places.iter().zip(values) {
            d.next[place.word] |= (value & place.mask) << place.shift;
        }
        for word in 0..d.next.len() {
            let next = d.next[word];
            d.write_word(&mut self.out, &mut self.now, word, t_fs, next)?;
        }
        Ok(())
    }

    /// As [`VcdTracer::device`] with the probe values packed as
    /// [`crate::engine::Device::packed_probe_values`] gives them.
    pub fn device_packed(
        &mut self,
        index: usize,
        t_fs: u64,
        tx: bool,
        rx: bool,
        packed: u64,
    ) -> io::Result<()> {
        let d = &mut self.devices[index];
        assert!(
            d.wires.len() <= 64,
            "{}: packed probe values need probes of at most 62 bits",
            d.name
        );
        let next = u64::from(tx) | u64::from(rx) << 1 | packed << 2;
        d.write_word(&mut self.out, &mut self.now, 0, t_fs, next)
    }

    /// Bus probe `index` (in the order given to [`VcdTracer::create`]) changes to `value` at
    /// `t_fs` (times never decrease across calls).
    pub fn bus_probe(&mut self, index: usize, t_fs: u64, value: u64) -> io::Result<()> {
        if self.bus_probes[index].last == value {
            return Ok(());
        }
        at(&mut self.out, &mut self.now, t_fs)?;
        write_probe(&mut self.out, &mut self.bus_probes[index], value)
    }

    /// Writes the final timestamp, flushes, and moves the file into place.
    pub fn finish(mut self, t_end_fs: u64) -> io::Result<PathBuf> {
        let end_ns = (t_end_fs + FS_PER_NS / 2) / FS_PER_NS;
        if end_ns > self.now.ns {
            self.out.advance_timestamp(&mut self.now, end_ns)?;
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

/// Writes the change lines of the bits set in `diff` to their values in `word`, bit `i` being
/// `wires[i]`.
#[inline]
fn write_bits(out: &mut Output, wires: &[Wire], mut diff: u64, word: u64) -> io::Result<()> {
    while diff != 0 {
        let bit = diff.trailing_zeros() as usize;
        diff &= diff - 1;
        out.change(&wires[bit], word >> bit & 1 == 1)?;
    }
    Ok(())
}

/// Writes the timestamp of `t_fs` unless it is the current one.
#[inline]
fn at(out: &mut Output, now: &mut TimestampLine, t_fs: u64) -> io::Result<()> {
    let ns = (t_fs + FS_PER_NS / 2) / FS_PER_NS;
    if ns != now.ns {
        out.advance_timestamp(now, ns)?;
    }
    Ok(())
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
    let diff = probe.last ^ value;
    probe.last = value;
    write_bits(out, &probe.bits, diff, value)
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
            let mut copy = line.text;
            line.advance(ns, &mut copy);
            assert_eq!(line.text(), &copy[..line.len]);
            let text = line.text().to_vec();
            assert_eq!(
                String::from_utf8(text).unwrap(),
                format!("#{ns}\n"),
                "after {step}"
            );
        }
        let mut line = TimestampLine::new(u64::MAX - 3);
        let mut copy = line.text;
        line.advance(u64::MAX, &mut copy);
        assert_eq!(line.text(), format!("#{}\n", u64::MAX).as_bytes());
        assert_eq!(&copy[..line.len], line.text());
    }

    /// Small steps (the common case, taken two digits at a time) from every kind of start.
    #[test]
    fn small_steps_read_as_the_number() {
        let mut seed = 3u64;
        for start in [0, 5, 95, 99_990, 999_999_950] {
            let mut line = TimestampLine::new(start);
            let mut ns = start;
            for _ in 0..20_000 {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ns += seed >> 33 & 0x7f;
                let mut copy = line.text;
                line.advance(ns, &mut copy);
                assert_eq!(line.text(), format!("#{ns}\n").as_bytes());
                assert_eq!(&copy[..line.len], line.text());
            }
        }
    }

    /// A device's probes written from packed values give the same file as from separate ones.
    #[test]
    fn packed_probe_values_are_traced_as_the_separate_values() {
        let probes = vec![
            Probe::bit("a"),
            Probe {
                name: "b",
                width: 5,
            },
            Probe {
                name: "c",
                width: 8,
            },
        ];
        let devices = [("n".to_string(), probes)];
        let dir = std::env::temp_dir().join(format!("cansim-trace-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let write = |name: &str, packed: bool| {
            let path = dir.join(name);
            let mut tracer = VcdTracer::create(&path, &[], &devices, None).unwrap();
            let mut seed = 1u64;
            for edge in 0..500u64 {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let (a, b, c) = (seed >> 20 & 1, seed >> 30 & 0x1f, seed >> 40 & 0xff);
                let (tx, rx) = (seed >> 50 & 1 == 1, seed >> 51 & 1 == 1);
                let t = edge * 62_500_000;
                if packed {
                    tracer
                        .device_packed(0, t, tx, rx, a | b << 1 | c << 6)
                        .unwrap();
                } else {
                    tracer.device(0, t, tx, rx, &[a, b, c]).unwrap();
                }
            }
            std::fs::read(tracer.finish(500 * 62_500_000).unwrap()).unwrap()
        };
        let separate = write("separate.vcd", false);
        assert_eq!(write("packed.vcd", true), separate);
        assert!(separate.len() > 10_000, "the values changed");
        std::fs::remove_dir_all(&dir).unwrap();
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
