//! PDOs (CiA 301 7.2.2): process data in up to 8 bytes, laid out by a mapping object and sent or
//! received on the COB-ID of a communication parameter object, unconfirmed, in operational only.
//!
//! Objects (7.5.2.35–7.5.2.38): RPDO n communication 1400h + n − 1 and mapping 1600h + n − 1,
//! TPDO n communication 1800h + n − 1 and mapping 1A00h + n − 1. Communication sub-index 1 is the
//! COB-ID (bit 31 set: the PDO is not valid; bit 30 set: no RTR allowed), 2 the transmission type
//! (0 synchronous acyclic, 1–240 every n-th SYNC, 252/253 on RTR, 254/255 event-driven), 3 the
//! inhibit time in 100 µs (the least time between two transmissions), 5 the event timer in ms, 6
//! the SYNC start value (a cyclic TPDO first goes out at the SYNC whose counter equals it). A
//! mapping entry is index (bits 31..16), sub-index (15..8) and length in bits (7..0); sub-index 0
//! counts them. Writing a count checks every entry (7.5.2.38): an object that does not exist or
//! may not be mapped aborts with 0604 0041, more than 64 bits with 0604 0042. An RPDO may map a
//! data type index (0001h–0007h, dummy mapping) to skip that many bits of the PDO.

use crate::od::ObjectDictionary;
use crate::sdo::Abort;
use crate::CanFrame;

/// First RPDO communication parameter object.
pub const RPDO_COMMUNICATION: u16 = 0x1400;
/// First RPDO mapping object.
pub const RPDO_MAPPING: u16 = 0x1600;
/// First TPDO communication parameter object.
pub const TPDO_COMMUNICATION: u16 = 0x1800;
/// First TPDO mapping object.
pub const TPDO_MAPPING: u16 = 0x1A00;
/// PDOs of each direction a device may have (CiA 301: 512).
const PDO_LIMIT: u16 = 0x200;
/// COB-ID bit 31: the PDO is not valid; bit 30: no RTR allowed.
const NOT_VALID: u64 = 1 << 31;
const NO_RTR: u64 = 1 << 30;
/// Data type indices an RPDO may map as dummies (BOOLEAN to UNSIGNED32).
const DUMMIES: std::ops::RangeInclusive<u16> = 0x0001..=0x0007;
/// COB-ID bits of an 11-bit identifier.
const COB_ID_MASK: u64 = 0x7FF;
/// Sub-indices of a communication parameter object.
const SUB_COB_ID: u8 = 1;
const SUB_TRANSMISSION_TYPE: u8 = 2;
const SUB_INHIBIT_TIME: u8 = 3;
const SUB_EVENT_TIMER: u8 = 5;
const SUB_SYNC_START: u8 = 6;
/// The most bits a PDO carries.
const MAX_BITS: u64 = 64;
/// Transmission types: synchronous every 1 to 240 SYNCs; event-driven.
const SYNC_CYCLIC: std::ops::RangeInclusive<u64> = 1..=240;
const EVENT_DRIVEN: std::ops::RangeInclusive<u64> = 254..=255;
const ON_RTR: std::ops::RangeInclusive<u64> = 252..=253;
/// Abort 0604 0041: object cannot be mapped to the PDO.
pub const NOT_MAPPABLE: Abort = Abort(0x0604_0041);
/// Abort 0604 0042: the number and length of the objects would exceed the PDO length.
pub const TOO_LONG: Abort = Abort(0x0604_0042);

/// Whether `index` is a mapping object.
pub fn is_mapping(index: u16) -> bool {
    (RPDO_MAPPING..RPDO_MAPPING + PDO_LIMIT).contains(&index)
        || (TPDO_MAPPING..TPDO_MAPPING + PDO_LIMIT).contains(&index)
}

/// A mapping entry: (index, sub-index, bits).
pub fn mapping_entry(value: u64) -> (u16, u8, u64) {
    ((value >> 16) as u16, (value >> 8) as u8, value & 0xFF)
}

/// Checks that the first `count` entries of mapping object `index` may be mapped.
pub fn check_mapping(od: &ObjectDictionary, index: u16, count: u64) -> Result<(), Abort> {
    let mut bits = 0;
    let receive = (RPDO_MAPPING..RPDO_MAPPING + PDO_LIMIT).contains(&index);
    for sub in 1..=count {
        let (object, object_sub, length) = mapping_entry(od.unsigned(index, sub as u8));
        if receive && DUMMIES.contains(&object) {
            let size = crate::od::DataType::from_index(object).and_then(|t| t.size());
            if size.map(|s| 8 * s as u64) != Some(length) {
                return Err(NOT_MAPPABLE);
            }
            bits += length;
            continue;
        }
        let target = od.entry(object, object_sub).map_err(|_| NOT_MAPPABLE)?;
        let size_bits = target.data_type.size().map(|s| 8 * s as u64);
        if !target.pdo_mappable || size_bits != Some(length) {
            return Err(NOT_MAPPABLE);
        }
        bits += length;
    }
    if bits > MAX_BITS {
        return Err(TOO_LONG);
    }
    Ok(())
}

/// A PDO as its objects configure it.
struct Pdo {
    cob_id: u16,
    rtr_allowed: bool,
    transmission_type: u64,
    inhibit_us: u64,
    event_timer_ms: u64,
    sync_start: u64,
    /// (index, sub-index, bits) of each mapped object, in order.
    mapped: Vec<(u16, u8, u64)>,
}

/// PDO number `k` (0-based) of the direction whose first objects are `communication` and
/// `mapping`, if it exists and is valid.
fn pdo(od: &ObjectDictionary, communication: u16, mapping: u16, k: u16) -> Option<Pdo> {
    od.entry(communication + k, SUB_COB_ID).ok()?;
    let cob_id = od.unsigned(communication + k, SUB_COB_ID);
    if cob_id & NOT_VALID != 0 {
        return None;
    }
    let count = od.unsigned(mapping + k, 0);
    let mapped = (1..=count)
        .map(|sub| mapping_entry(od.unsigned(mapping + k, sub as u8)))
        .collect();
    let parameter = |sub| od.unsigned(communication + k, sub);
    Some(Pdo {
        cob_id: (cob_id & COB_ID_MASK) as u16,
        rtr_allowed: cob_id & NO_RTR == 0,
        transmission_type: parameter(SUB_TRANSMISSION_TYPE),
        inhibit_us: parameter(SUB_INHIBIT_TIME) * 100,
        event_timer_ms: parameter(SUB_EVENT_TIMER),
        sync_start: parameter(SUB_SYNC_START),
        mapped,
    })
}

/// The TPDOs of a device in operational: SYNC counting and event timers.
#[derive(Clone, Debug, Default)]
pub struct Tpdos {
    /// SYNCs counted per TPDO since it last went out.
    sync_counts: Vec<u64>,
    /// When each event-driven TPDO with an event timer goes out next.
    due_us: Vec<Option<u64>>,
    /// When each TPDO last went out (for its inhibit time).
    sent_us: Vec<Option<u64>>,
    /// Whether each cyclic TPDO with a SYNC start value has met it.
    started: Vec<bool>,
}

/// The TPDOs a dictionary has (their communication objects exist).
fn tpdo_numbers(od: &ObjectDictionary) -> impl Iterator<Item = u16> + '_ {
    (0..PDO_LIMIT).filter(|k| od.objects.contains_key(&(TPDO_COMMUNICATION + k)))
}

/// TPDO `k`'s frame: its mapped values, in order.
fn tpdo_frame(od: &ObjectDictionary, pdo: &Pdo) -> CanFrame {
    let mut data = Vec::new();
    for &(index, sub, _) in &pdo.mapped {
        if let Ok(entry) = od.entry(index, sub) {
            data.extend_from_slice(&entry.value);
        }
    }
    data.truncate(8);
    CanFrame::new(pdo.cob_id, &data)
}

impl Tpdos {
    /// Entering operational at `now_us`: counts start from zero, event timers run.
    pub fn start(&mut self, od: &ObjectDictionary, now_us: u64) {
        let count = usize::from(tpdo_numbers(od).last().map_or(0, |k| k + 1));
        self.sync_counts = vec![0; count];
        self.sent_us = vec![None; count];
        self.started = vec![false; count];
        self.due_us = (0..count as u16)
            .map(|k| {
                let pdo = pdo(od, TPDO_COMMUNICATION, TPDO_MAPPING, k)?;
                let timed = EVENT_DRIVEN.contains(&pdo.transmission_type) && pdo.event_timer_ms > 0;
                timed.then_some(now_us + pdo.event_timer_ms * 1000)
            })
            .collect();
    }

    /// A SYNC (with its counter, if it has one) at `now_us`: the synchronous TPDOs whose turn it
    /// is.
    pub fn sync(
        &mut self,
        od: &ObjectDictionary,
        counter: Option<u8>,
        now_us: u64,
    ) -> Vec<CanFrame> {
        let mut out = Vec::new();
        for n in tpdo_numbers(od) {
            let k = usize::from(n);
            let Some(pdo) = pdo(od, TPDO_COMMUNICATION, TPDO_MAPPING, n) else {
                continue;
            };
            if k >= self.sync_counts.len() || !self.sync_turn(k, &pdo, counter) {
                continue;
            }
            out.push(tpdo_frame(od, &pdo));
            self.sent_us[k] = Some(now_us);
        }
        out
    }

    /// Whether TPDO `k` goes out at this SYNC: every SYNC for type 0, every n-th for 1 to 240
    /// (from the SYNC whose counter is its start value, if it has one).
    fn sync_turn(&mut self, k: usize, pdo: &Pdo, counter: Option<u8>) -> bool {
        if pdo.transmission_type == 0 {
            return true;
        }
        if !SYNC_CYCLIC.contains(&pdo.transmission_type) {
            return false;
        }
        if pdo.sync_start > 0 && !self.started[k] {
            // 7.5.2.36: the first transmission is at the SYNC whose counter is the start value.
            if counter.map(u64::from) != Some(pdo.sync_start) {
                return false;
            }
            self.started[k] = true;
            self.sync_counts[k] = pdo.transmission_type - 1;
        }
        self.sync_counts[k] += 1;
        if self.sync_counts[k] < pdo.transmission_type {
            return false;
        }
        self.sync_counts[k] = 0;
        true
    }

    /// A remote frame on `id`: the TPDO of that COB-ID with transmission type 252 or 253 that
    /// allows RTR, with its values now.
    pub fn rtr(&mut self, od: &ObjectDictionary, id: u16, now_us: u64) -> Option<CanFrame> {
        let k = tpdo_numbers(od).find(|&k| {
            pdo(od, TPDO_COMMUNICATION, TPDO_MAPPING, k).is_some_and(|p| {
                p.cob_id == id && p.rtr_allowed && ON_RTR.contains(&p.transmission_type)
            })
        })?;
        let pdo = pdo(od, TPDO_COMMUNICATION, TPDO_MAPPING, k)?;
        if let Some(sent) = self.sent_us.get_mut(usize::from(k)) {
            *sent = Some(now_us);
        }
        Some(tpdo_frame(od, &pdo))
    }

    /// At `now_us`: the event-driven TPDOs whose event timer ran out.
    pub fn tick(&mut self, od: &ObjectDictionary, now_us: u64) -> Vec<CanFrame> {
        let mut out = Vec::new();
        for k in 0..self.due_us.len() {
            let Some(due) = self.due_us[k].filter(|&due| now_us >= due) else {
                continue;
            };
            let Some(pdo) = pdo(od, TPDO_COMMUNICATION, TPDO_MAPPING, k as u16) else {
                self.due_us[k] = None;
                continue;
            };
            // The inhibit time keeps it back until that long after it last went out.
            let free_at = self.sent_us[k].map_or(0, |sent| sent + pdo.inhibit_us);
            if now_us < free_at {
                self.due_us[k] = Some(free_at);
                continue;
            }
            out.push(tpdo_frame(od, &pdo));
            self.sent_us[k] = Some(now_us);
            self.due_us[k] = Some(due.max(now_us) + pdo.event_timer_ms.max(1) * 1000);
        }
        out
    }

    /// When an event timer runs out next.
    pub fn deadline(&self) -> Option<u64> {
        self.due_us.iter().flatten().min().copied()
    }
}

/// A frame on the COB-ID of a valid RPDO writes its mapped objects (in operational); whether it
/// was one.
pub fn receive_rpdo(od: &mut ObjectDictionary, frame: &CanFrame) -> bool {
    let rpdo = (0..PDO_LIMIT)
        .filter(|k| od.objects.contains_key(&(RPDO_COMMUNICATION + k)))
        .filter_map(|k| pdo(od, RPDO_COMMUNICATION, RPDO_MAPPING, k))
        .find(|pdo| pdo.cob_id == frame.id);
    let Some(rpdo) = rpdo else {
        return false;
    };
    let mut offset = 0;
    for (index, sub, bits) in rpdo.mapped {
        if DUMMIES.contains(&index) {
            offset += (bits / 8) as usize;
            continue;
        }
        let Some(size) = od.entry(index, sub).ok().and_then(|e| e.data_type.size()) else {
            continue;
        };
        if let Some(bytes) = frame.data.get(offset..offset + size) {
            od.set(index, sub, bytes);
        }
        offset += size;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eds;
    use std::path::Path;

    /// TPDO1 and RPDO1 of node 1 with their mappings, 6000h:1 (UNSIGNED8, mappable), 1008h (not
    /// mappable), 2000h (UNSIGNED16, mappable).
    const EDS: &str = "\
[MandatoryObjects]
SupportedObjects=8
1=0x1008
2=0x1400
3=0x1600
4=0x1800
5=0x1A00
6=0x2000
7=0x6000
8=0x6200
[1008]
ParameterName=Name
DataType=0x0009
AccessType=const
DefaultValue=x
[1400]
ParameterName=RPDO1
ObjectType=0x9
[1400sub0]
ParameterName=n
DataType=0x0005
AccessType=const
DefaultValue=2
[1400sub1]
ParameterName=COB-ID
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x200
[1400sub2]
ParameterName=type
DataType=0x0005
AccessType=rw
DefaultValue=255
[1600]
ParameterName=RPDO1 mapping
ObjectType=0x9
[1600sub0]
ParameterName=n
DataType=0x0005
AccessType=rw
DefaultValue=1
[1600sub1]
ParameterName=1
DataType=0x0007
AccessType=rw
DefaultValue=0x62000108
[1600sub2]
ParameterName=2
DataType=0x0007
AccessType=rw
DefaultValue=0
[1800]
ParameterName=TPDO1
ObjectType=0x9
[1800sub0]
ParameterName=n
DataType=0x0005
AccessType=const
DefaultValue=5
[1800sub1]
ParameterName=COB-ID
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x180
[1800sub2]
ParameterName=type
DataType=0x0005
AccessType=rw
DefaultValue=2
[1800sub3]
ParameterName=inhibit time
DataType=0x0006
AccessType=rw
DefaultValue=0
[1800sub5]
ParameterName=event timer
DataType=0x0006
AccessType=rw
DefaultValue=0
[1800sub6]
ParameterName=SYNC start value
DataType=0x0005
AccessType=rw
DefaultValue=0
[1A00]
ParameterName=TPDO1 mapping
ObjectType=0x9
[1A00sub0]
ParameterName=n
DataType=0x0005
AccessType=rw
DefaultValue=2
[1A00sub1]
ParameterName=1
DataType=0x0007
AccessType=rw
DefaultValue=0x60000108
[1A00sub2]
ParameterName=2
DataType=0x0007
AccessType=rw
DefaultValue=0x20000010
[1A00sub3]
ParameterName=3
DataType=0x0007
AccessType=rw
DefaultValue=0
[2000]
ParameterName=Word
DataType=0x0006
AccessType=rw
DefaultValue=0x1234
PDOMapping=1
[6000]
ParameterName=In
ObjectType=0x8
[6000sub0]
ParameterName=n
DataType=0x0005
AccessType=const
DefaultValue=1
[6000sub1]
ParameterName=In 1-8
DataType=0x0005
AccessType=ro
DefaultValue=0x5A
PDOMapping=1
[6200]
ParameterName=Out
ObjectType=0x8
[6200sub0]
ParameterName=n
DataType=0x0005
AccessType=const
DefaultValue=1
[6200sub1]
ParameterName=Out 1-8
DataType=0x0005
AccessType=rw
DefaultValue=0
PDOMapping=1
";

    fn od() -> ObjectDictionary {
        eds::parse(EDS, Path::new("t.eds"), 1).unwrap()
    }

    #[test]
    fn a_tpdo_of_type_2_goes_out_on_every_second_sync_with_its_mapped_values() {
        let od = od();
        let mut tpdos = Tpdos::default();
        tpdos.start(&od, 0);
        assert!(tpdos.sync(&od, None, 0).is_empty(), "first SYNC");
        assert_eq!(
            tpdos.sync(&od, None, 0),
            [CanFrame::new(0x181, &[0x5A, 0x34, 0x12])]
        );
        assert!(tpdos.sync(&od, None, 0).is_empty());
    }

    #[test]
    fn an_event_timer_sends_an_event_driven_tpdo_periodically() {
        let mut od = od();
        od.write(0x1800, 2, &[255]).unwrap();
        od.write(0x1800, 5, &[10, 0]).unwrap();
        let mut tpdos = Tpdos::default();
        tpdos.start(&od, 1_000);
        assert_eq!(tpdos.deadline(), Some(11_000));
        assert!(tpdos.tick(&od, 10_999).is_empty());
        assert_eq!(tpdos.tick(&od, 11_000).len(), 1);
        assert_eq!(tpdos.deadline(), Some(21_000));
    }

    #[test]
    fn an_rpdo_writes_its_mapped_object_and_an_invalid_pdo_is_silent() {
        let mut od = od();
        assert!(receive_rpdo(&mut od, &CanFrame::new(0x201, &[0x33])));
        assert_eq!(od.unsigned(0x6200, 1), 0x33);
        assert!(!receive_rpdo(&mut od, &CanFrame::new(0x202, &[0x44])));
        od.write(0x1800, 1, &0x8000_0181u32.to_le_bytes()).unwrap();
        let mut tpdos = Tpdos::default();
        tpdos.start(&od, 0);
        tpdos.sync(&od, None, 0);
        assert!(tpdos.sync(&od, None, 0).is_empty(), "bit 31: not valid");
    }

    #[test]
    fn a_tpdo_of_type_253_answers_a_remote_frame_unless_rtr_is_not_allowed() {
        let mut od = od();
        od.write(0x1800, 2, &[253]).unwrap();
        let mut tpdos = Tpdos::default();
        tpdos.start(&od, 0);
        assert!(tpdos.sync(&od, None, 0).is_empty(), "not on SYNC");
        assert_eq!(
            tpdos.rtr(&od, 0x181, 0),
            Some(CanFrame::new(0x181, &[0x5A, 0x34, 0x12]))
        );
        assert_eq!(tpdos.rtr(&od, 0x182, 0), None, "another COB-ID");
        od.write(0x1800, 1, &0x4000_0181u32.to_le_bytes()).unwrap();
        assert_eq!(tpdos.rtr(&od, 0x181, 0), None, "bit 30: no RTR allowed");
    }

    #[test]
    fn the_inhibit_time_holds_an_event_driven_tpdo_back() {
        let mut od = od();
        od.write(0x1800, 2, &[254]).unwrap();
        od.write(0x1800, 5, &[1, 0]).unwrap();
        // 50 x 100 us = 5 ms between transmissions; the event timer asks every 1 ms.
        od.write(0x1800, 3, &[50, 0]).unwrap();
        let mut tpdos = Tpdos::default();
        tpdos.start(&od, 0);
        assert_eq!(tpdos.tick(&od, 1_000).len(), 1);
        assert!(tpdos.tick(&od, 2_000).is_empty());
        assert_eq!(tpdos.deadline(), Some(6_000));
        assert_eq!(tpdos.tick(&od, 6_000).len(), 1);
    }

    #[test]
    fn a_sync_start_value_delays_the_first_cyclic_tpdo_to_that_counter() {
        let mut od = od();
        od.write(0x1800, 6, &[3]).unwrap();
        let mut tpdos = Tpdos::default();
        tpdos.start(&od, 0);
        let sent: Vec<bool> = [1, 2, 3, 4, 5, 1]
            .iter()
            .map(|&c| !tpdos.sync(&od, Some(c), 0).is_empty())
            .collect();
        // Type 2: first at counter 3, then every second SYNC.
        assert_eq!(sent, [false, false, true, false, true, false]);
    }

    #[test]
    fn a_dummy_entry_of_an_rpdo_skips_its_bytes() {
        let mut od = od();
        // RPDO1: UNSIGNED16 dummy (0006h, 16 bits), then 6200h:1.
        od.write(0x1600, 1, &0x0006_0010u32.to_le_bytes()).unwrap();
        od.write(0x1600, 2, &0x6200_0108u32.to_le_bytes()).unwrap();
        assert_eq!(od.write(0x1600, 0, &[2]), Ok(()));
        assert!(receive_rpdo(
            &mut od,
            &CanFrame::new(0x201, &[0xAA, 0xBB, 0x44])
        ));
        assert_eq!(od.unsigned(0x6200, 1), 0x44);
        // A TPDO may not map a dummy.
        od.write(0x1A00, 3, &0x0006_0010u32.to_le_bytes()).unwrap();
        assert_eq!(od.write(0x1A00, 0, &[3]), Err(NOT_MAPPABLE));
    }

    #[test]
    fn mapping_counts_are_checked_when_written() {
        let mut od = od();
        od.write(0x1A00, 3, &((0x1008u32 << 16) | 8).to_le_bytes())
            .unwrap();
        assert_eq!(od.write(0x1A00, 0, &[3]), Err(NOT_MAPPABLE));
        od.write(0x1A00, 3, &((0x2000u32 << 16) | 8).to_le_bytes())
            .unwrap();
        assert_eq!(
            od.write(0x1A00, 0, &[3]),
            Err(NOT_MAPPABLE),
            "8 bits of a 16-bit object"
        );
        od.write(0x1A00, 3, &((0x3000u32 << 16) | 8).to_le_bytes())
            .unwrap();
        assert_eq!(
            od.write(0x1A00, 0, &[3]),
            Err(NOT_MAPPABLE),
            "no such object"
        );
        for sub in 1..=3 {
            od.write(0x1A00, sub, &((0x2000u32 << 16) | 16).to_le_bytes())
                .unwrap();
        }
        assert_eq!(od.write(0x1A00, 0, &[3]), Ok(()), "48 bits");
        assert_eq!(od.unsigned(0x1A00, 0), 3);
    }
}
