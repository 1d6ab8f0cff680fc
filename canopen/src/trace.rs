//! CANopen frames in words, for bus logs: which service a frame belongs to by its COB-ID (the
//! predefined connection set, CiA 301 7.3.5 Table 79) and what it says: NMT commands, SYNC, EMCY
//! codes, TIME stamps, PDO values by the mapping of the producing or consuming node, SDO requests
//! and responses with index:sub-index and the object's name, boot-up and heartbeat states.
//!
//! A [`Tracer`] knows the object dictionaries of some nodes (from their EDS files) and follows
//! the SDO downloads it sees to PDO mapping and communication objects, so PDOs configured at run
//! time are read with the mapping in force.

use std::collections::BTreeMap;

use crate::od::ObjectDictionary;
use crate::pdo::mapping_entry;
use crate::time_stamp::TimeOfDay;
use crate::CanFrame;

/// Function codes (bits 10..7 of the COB-ID) of the predefined connection set.
const NMT: u16 = 0x000;
const SYNC_OR_EMCY: u16 = 0x080;
const TIME: u16 = 0x100;
const SDO_RESPONSE: u16 = 0x580;
const SDO_REQUEST: u16 = 0x600;
const ERROR_CONTROL: u16 = 0x700;
/// PDO function codes and names: TPDO1 180h, RPDO1 200h, … RPDO4 500h.
const PDOS: [(u16, &str, u16, u16); 8] = [
    (0x180, "TPDO1", 0x1800, 0x1A00),
    (0x200, "RPDO1", 0x1400, 0x1600),
    (0x280, "TPDO2", 0x1801, 0x1A01),
    (0x300, "RPDO2", 0x1401, 0x1601),
    (0x380, "TPDO3", 0x1802, 0x1A02),
    (0x400, "RPDO3", 0x1402, 0x1602),
    (0x480, "TPDO4", 0x1803, 0x1A03),
    (0x500, "RPDO4", 0x1403, 0x1603),
];

/// Reads CANopen frames, knowing the dictionaries of some nodes.
#[derive(Clone, Debug, Default)]
pub struct Tracer {
    nodes: BTreeMap<u8, ObjectDictionary>,
    /// Per node: its block transfer, if one is open.
    blocks: BTreeMap<u8, BlockTrace>,
}

/// What the tracer follows of a block transfer: its segments carry no command specifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct BlockTrace {
    /// The segments come from the client (download) or the server (upload).
    from_client: bool,
    /// Segments are on the way now.
    segments: bool,
    /// The last segment came.
    last: bool,
}

impl Tracer {
    /// A tracer that knows `nodes` (node-ID → dictionary at its defaults).
    pub fn new(nodes: BTreeMap<u8, ObjectDictionary>) -> Tracer {
        Tracer {
            nodes,
            blocks: BTreeMap::new(),
        }
    }

    /// `frame` in words (and what it changes of the known dictionaries).
    pub fn describe(&mut self, frame: &CanFrame) -> String {
        let id = frame.id;
        let node = (id & 0x7F) as u8;
        let function = id & !0x7F;
        let data = &frame.data;
        match function {
            NMT if id == NMT => nmt(data),
            SYNC_OR_EMCY if id == SYNC_OR_EMCY => match data.first() {
                Some(counter) => format!("SYNC {counter}"),
                None => "SYNC".to_string(),
            },
            SYNC_OR_EMCY => emcy(node, data),
            TIME if id == TIME => time_stamp(data),
            SDO_REQUEST => self.sdo(node, data, true),
            SDO_RESPONSE => self.sdo(node, data, false),
            ERROR_CONTROL if frame.remote => format!("node guarding request to node {node}"),
            ERROR_CONTROL => error_control(node, data),
            _ => self.pdo(id, frame),
        }
    }

    fn name(&self, node: u8, index: u16, sub: u8) -> String {
        let Some(od) = self.nodes.get(&node) else {
            return String::new();
        };
        let Some(object) = od.objects.get(&index) else {
            return " (not in the EDS)".to_string();
        };
        match object.entries.get(&sub) {
            Some(entry) if object.entries.len() > 1 => {
                format!(" ({}: {})", object.name, entry.name)
            }
            _ => format!(" ({})", object.name),
        }
    }

    fn sdo(&mut self, node: u8, data: &[u8], request: bool) -> String {
        let who = if request {
            "SDO request to"
        } else {
            "SDO response of"
        };
        let Some(&command) = data.first().filter(|_| data.len() == 8) else {
            return format!("{who} node {node}: not 8 bytes");
        };
        let block = self.blocks.get(&node);
        if block.is_some_and(|b| b.segments && b.from_client == request) {
            return format!("{who} node {node}: {}", self.block_segment(node, command));
        }
        let index = u16::from_le_bytes([data[1], data[2]]);
        let sub = data[3];
        let place = format!("{index:04X}h:{sub:02X}{}", self.name(node, index, sub));
        let specifier = command >> 5;
        let what = match (request, specifier) {
            (_, 4) => {
                let code = u32::from_le_bytes([data[4], data[5], data[6], data[7]]);
                format!("abort {place}: {:04X} {:04X}", code >> 16, code & 0xFFFF)
            }
            (true, 1) if command & 0x02 != 0 => {
                let len = if command & 0x01 != 0 {
                    4 - usize::from((command >> 2) & 3)
                } else {
                    4
                };
                let bytes = &data[4..4 + len];
                self.follow_download(node, index, sub, bytes);
                format!("download {place} = {}", self.value(node, index, sub, bytes))
            }
            (true, 1) => format!("download {place}, segmented"),
            (true, 0) => format!("download segment{}", last(command)),
            (false, 1) => "download segment confirmed".to_string(),
            (false, 3) => format!("download {place} confirmed"),
            (true, 2) => format!("upload {place}"),
            (false, 2) if command & 0x02 != 0 => {
                let len = 4 - usize::from((command >> 2) & 3);
                let value = self.value(node, index, sub, &data[4..4 + len]);
                format!("upload {place} = {value}")
            }
            (false, 2) => format!("upload {place}, segmented"),
            (true, 3) => "upload segment request".to_string(),
            (false, 0) => format!("upload segment{}", last(command)),
            (true, 6) | (false, 5) | (true, 5) | (false, 6) => {
                self.block(node, request, data, &place)
            }
            _ => "unknown command".to_string(),
        };
        format!("{who} node {node}: {what}")
    }

    /// A block transfer's segment (its sequence number, bit 7 on the last).
    fn block_segment(&mut self, node: u8, command: u8) -> String {
        let last = command & 0x80 != 0;
        if let (Some(block), true) = (self.blocks.get_mut(&node), last) {
            (block.segments, block.last) = (false, true);
        }
        format!(
            "block segment {}{}",
            command & 0x7F,
            if last { ", last" } else { "" }
        )
    }

    /// A command of a block transfer (CiA 301 7.2.4.3.9–7.2.4.3.16), following when segments
    /// come.
    fn block(&mut self, node: u8, request: bool, data: &[u8], place: &str) -> String {
        let command = data[0];
        let download = (command >> 5 == 6) == request;
        let size = u32::from_le_bytes([data[4], data[5], data[6], data[7]]);
        let crc = u16::from_le_bytes([data[1], data[2]]);
        // The sub-command: bits 1..0 for the side that receives the segments, bit 0 for the side
        // that sends them.
        let sub_command = command & if download == request { 0x01 } else { 0x03 };
        let unused = (command >> 2) & 0x07;
        let confirmed = |what: &str| {
            format!(
                "block {what}: {} segments confirmed, {} per block",
                data[1], data[2]
            )
        };
        let (text, segments_follow) = match (download, request, sub_command) {
            (_, true, 0) => {
                self.blocks.insert(
                    node,
                    BlockTrace {
                        from_client: download,
                        segments: false,
                        last: false,
                    },
                );
                if download {
                    (format!("block download {place}, {size} bytes"), false)
                } else {
                    let per_block = data[4];
                    (
                        format!("block upload {place}: {per_block} segments per block"),
                        false,
                    )
                }
            }
            (true, false, 0) => (
                format!("block download {place}: {} segments per block", data[4]),
                true,
            ),
            (false, false, 0) => (format!("block upload {place}, {size} bytes"), false),
            (false, true, 3) => ("block upload start".to_string(), true),
            (true, false, 2) => (confirmed("download"), true),
            (false, true, 2) => (confirmed("upload"), true),
            (_, _, 1) if download == request => (
                format!(
                    "block {} end: {unused} bytes unused, CRC {crc:04X}h",
                    if download { "download" } else { "upload" }
                ),
                false,
            ),
            (_, _, 1) => {
                self.blocks.remove(&node);
                let what = if download { "download" } else { "upload" };
                (format!("block {what} ended"), false)
            }
            _ => ("block transfer: unknown command".to_string(), false),
        };
        if let Some(block) = self.blocks.get_mut(&node) {
            block.segments = segments_follow && !block.last;
        }
        text
    }

    /// `bytes` of `index`:`sub` of `node`: a number when the EDS says it is an integer (in hex
    /// for the 32-bit communication objects: COB-IDs and mapping entries), else the bytes.
    fn value(&self, node: u8, index: u16, sub: u8, bytes: &[u8]) -> String {
        let number = self
            .nodes
            .get(&node)
            .and_then(|od| od.entry(index, sub).ok())
            .filter(|entry| entry.data_type.size() == Some(bytes.len()))
            .and_then(|entry| entry.data_type.number(bytes));
        match number {
            Some(n) if (0x1000..0x2000).contains(&index) && bytes.len() == 4 => format!("{n:X}h"),
            Some(n) => n.to_string(),
            None => hex(bytes),
        }
    }

    /// An expedited download the tracer saw: keeps PDO parameters current.
    fn follow_download(&mut self, node: u8, index: u16, sub: u8, bytes: &[u8]) {
        if let Some(od) = self.nodes.get_mut(&node) {
            od.set(index, sub, bytes);
        }
    }

    fn pdo(&self, id: u16, frame: &CanFrame) -> String {
        let node = (id & 0x7F) as u8;
        let Some(&(_, name, communication, mapping)) =
            PDOS.iter().find(|(base, ..)| id & !0x7F == *base)
        else {
            return String::new();
        };
        let mut text = format!("{name} of node {node}");
        let Some(od) = self.nodes.get(&node) else {
            return text;
        };
        // The COB-ID in force may differ from the default; only a PDO mapped as seen is decoded.
        if od.unsigned(communication, 1) & 0x7FF != u64::from(id) {
            return text;
        }
        let mut offset = 0;
        for sub in 1..=od.unsigned(mapping, 0) {
            let value = od.unsigned(mapping, sub as u8);
            let (index, object_sub, bits) = mapping_entry(value);
            let bytes = (bits / 8) as usize;
            let Some(field) = frame.data.get(offset..offset + bytes) else {
                break;
            };
            offset += bytes;
            let Ok(entry) = od.entry(index, object_sub) else {
                continue;
            };
            let shown = entry
                .data_type
                .number(field)
                .map_or_else(|| hex(field), |n| n.to_string());
            text += &format!(", {} = {shown}", entry.name);
        }
        text
    }
}

fn nmt(data: &[u8]) -> String {
    let [command, node] = data else {
        return "NMT: not 2 bytes".to_string();
    };
    let what = match command {
        0x01 => "start",
        0x02 => "stop",
        0x80 => "enter pre-operational",
        0x81 => "reset node",
        0x82 => "reset communication",
        _ => "unknown command",
    };
    match node {
        0 => format!("NMT {what}, all nodes"),
        node => format!("NMT {what}, node {node}"),
    }
}

fn emcy(node: u8, data: &[u8]) -> String {
    if data.len() < 3 {
        return format!("EMCY of node {node}: too short");
    }
    let code = u16::from_le_bytes([data[0], data[1]]);
    let meaning = match code {
        0x0000 => " (error reset)",
        0x8130 => " (life guard or heartbeat error)",
        0x8100..=0x81FF => " (communication)",
        0x1000..=0x10FF => " (generic error)",
        _ => "",
    };
    format!(
        "EMCY of node {node}: {code:04X}h{meaning}, error register {:02X}h",
        data[2]
    )
}

fn error_control(node: u8, data: &[u8]) -> String {
    let Some(&state) = data.first() else {
        return format!("error control of node {node}: no data");
    };
    let what = match state & 0x7F {
        0x00 => return format!("boot-up of node {node}"),
        0x04 => "stopped",
        0x05 => "operational",
        0x7F => "pre-operational",
        _ => "unknown state",
    };
    format!("heartbeat of node {node}: {what}")
}

/// A TIME message: its date and time of day.
fn time_stamp(data: &[u8]) -> String {
    match TimeOfDay::decode(data) {
        Some(time) => format!("TIME {time}"),
        None => "TIME: not 6 bytes".to_string(),
    }
}

/// `, last` for a segment with the c bit (bit 0).
fn last(command: u8) -> &'static str {
    if command & 0x01 != 0 {
        ", last"
    } else {
        ""
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eds;
    use std::path::Path;

    const EDS: &str = "\
[MandatoryObjects]
SupportedObjects=5
1=0x1008
2=0x1800
3=0x1A00
4=0x2000
5=0x6000
[1008]
ParameterName=Manufacturer device name
DataType=0x0009
AccessType=const
DefaultValue=x
[1800]
ParameterName=TPDO1 communication parameter
ObjectType=0x9
[1800sub0]
ParameterName=Highest sub-index supported
DataType=0x0005
AccessType=const
DefaultValue=1
[1800sub1]
ParameterName=COB-ID used by TPDO1
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x80000180
[1A00]
ParameterName=TPDO1 mapping parameter
ObjectType=0x9
[1A00sub0]
ParameterName=Number of mapped objects
DataType=0x0005
AccessType=rw
DefaultValue=0
[1A00sub1]
ParameterName=Object 1
DataType=0x0007
AccessType=rw
DefaultValue=0
[1A00sub2]
ParameterName=Object 2
DataType=0x0007
AccessType=rw
DefaultValue=0
[2000]
ParameterName=Input debounce time
DataType=0x0006
AccessType=rw
DefaultValue=10
PDOMapping=1
[6000]
ParameterName=Read input 8-bit
ObjectType=0x8
[6000sub0]
ParameterName=Number
DataType=0x0005
AccessType=const
DefaultValue=1
[6000sub1]
ParameterName=Inputs 1-8
DataType=0x0005
AccessType=ro
DefaultValue=0x5A
PDOMapping=1
";

    fn tracer() -> Tracer {
        let od = eds::parse(EDS, Path::new("t.eds"), 2).unwrap();
        Tracer::new(BTreeMap::from([(2, od)]))
    }

    fn said(tracer: &mut Tracer, id: u16, data: &[u8]) -> String {
        tracer.describe(&CanFrame::new(id, data))
    }

    #[test]
    fn nmt_sync_emcy_time_and_error_control_in_words() {
        let mut t = tracer();
        assert_eq!(said(&mut t, 0x000, &[0x01, 0]), "NMT start, all nodes");
        assert_eq!(
            said(&mut t, 0x000, &[0x82, 2]),
            "NMT reset communication, node 2"
        );
        assert_eq!(said(&mut t, 0x080, &[]), "SYNC");
        assert_eq!(said(&mut t, 0x080, &[3]), "SYNC 3");
        assert_eq!(
            said(&mut t, 0x082, &[0x30, 0x81, 0x11, 0, 0, 0, 0, 0]),
            "EMCY of node 2: 8130h (life guard or heartbeat error), error register 11h"
        );
        // 0 ms after midnight of day 15000 after 1984-01-01, then 12:34:56.789 of day 0.
        assert_eq!(
            said(&mut t, 0x100, &[0, 0, 0, 0, 0x98, 0x3A]),
            "TIME 2025-01-25 00:00:00.000"
        );
        let ms = 45_296_789u32.to_le_bytes();
        assert_eq!(
            said(&mut t, 0x100, &[ms[0], ms[1], ms[2], ms[3], 0, 0]),
            "TIME 1984-01-01 12:34:56.789"
        );
        assert_eq!(said(&mut t, 0x702, &[0x00]), "boot-up of node 2");
        assert_eq!(
            said(&mut t, 0x702, &[0x7F]),
            "heartbeat of node 2: pre-operational"
        );
        assert_eq!(
            said(&mut t, 0x703, &[0x85]),
            "heartbeat of node 3: operational",
            "toggle bit"
        );
    }

    #[test]
    fn sdo_with_object_names_and_pdos_with_the_mapping_the_sdo_set() {
        let mut t = tracer();
        assert_eq!(
            said(&mut t, 0x602, &[0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
            "SDO request to node 2: upload 1008h:00 (Manufacturer device name)"
        );
        assert_eq!(
            said(
                &mut t,
                0x582,
                &[0x80, 0x00, 0x30, 0x00, 0x00, 0x00, 0x02, 0x06]
            ),
            "SDO response of node 2: abort 3000h:00 (not in the EDS): 0602 0000"
        );
        assert_eq!(
            said(&mut t, 0x182, &[0x5A]),
            "TPDO1 of node 2",
            "not valid: not decoded"
        );
        // Mapping by SDO as a master does it: 6000h:1 (8 bits), 2000h (16 bits), COB-ID valid.
        for (sub, value) in [(1u8, 0x6000_0108u32), (2, 0x2000_0010)] {
            let v = value.to_le_bytes();
            said(
                &mut t,
                0x602,
                &[0x23, 0x00, 0x1A, sub, v[0], v[1], v[2], v[3]],
            );
        }
        said(&mut t, 0x602, &[0x2F, 0x00, 0x1A, 0x00, 2, 0, 0, 0]);
        said(&mut t, 0x602, &[0x23, 0x00, 0x18, 0x01, 0x82, 0x01, 0, 0]);
        assert_eq!(
            said(&mut t, 0x182, &[0x5A, 0xFA, 0x00]),
            "TPDO1 of node 2, Inputs 1-8 = 90, Input debounce time = 250"
        );
    }
}
