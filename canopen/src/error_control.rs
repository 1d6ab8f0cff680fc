//! SYNC production, EMCY production and heartbeat consumption (CiA 301 7.2.5, 7.2.7, 7.2.8.3.2).
//!
//! * SYNC producer: when bit 30 of 1005h (COB-ID SYNC) is set, a SYNC goes out on its COB-ID every
//!   1006h microseconds; with 1019h (synchronous counter overflow) above 1 it carries a counter
//!   that runs from 1 to that value (7.2.5.3, 7.5.2.6, 7.5.2.22).
//! * EMCY producer: an error is reported on 1014h (COB-ID EMCY, default 80h + node-ID) as the
//!   error code (2 bytes), the error register 1001h (1 byte) and 5 manufacturer bytes of 0; 1003h
//!   (pre-defined error field) keeps the codes, newest at sub-index 1; 1015h (inhibit time, in
//!   100 µs) spaces EMCY messages (7.2.7.3.1, 7.5.2.2, 7.5.2.4, 7.5.2.17, 7.5.2.18).
//! * Heartbeat consumer: each 1016h entry (node-ID in bits 23..16, time in ms in bits 15..0)
//!   watches one producer from its first heartbeat on; a heartbeat missing for that long is a
//!   heartbeat event: EMCY 8130h (life guard or heartbeat error, Table 21) with the communication
//!   bit (4) and the generic bit (0) of the error register set. When that node's heartbeat comes
//!   back, EMCY 0000h (error reset) with the register cleared (7.2.8.3.2.2).

use crate::od::ObjectDictionary;
use crate::CanFrame;

/// COB-ID SYNC: bit 30 set makes this device the SYNC producer.
const COB_ID_SYNC: u16 = 0x1005;
const SYNC_GENERATE: u64 = 1 << 30;
/// Communication cycle period, µs.
const CYCLE_PERIOD: u16 = 0x1006;
/// Synchronous counter overflow value.
const COUNTER_OVERFLOW: u16 = 0x1019;
/// Error register and the pre-defined error field.
pub const ERROR_REGISTER: u16 = 0x1001;
const ERROR_FIELD: u16 = 0x1003;
/// COB-ID EMCY and its inhibit time (100 µs).
const COB_ID_EMCY: u16 = 0x1014;
const EMCY_INHIBIT: u16 = 0x1015;
/// Consumer heartbeat time.
const CONSUMER_HEARTBEAT: u16 = 0x1016;
/// Function code of EMCY and of heartbeats.
const EMCY_BASE: u16 = 0x080;
const HEARTBEAT_BASE: u16 = 0x700;
/// Error register bits (7.5.2.2, Table 48).
const GENERIC_ERROR: u8 = 0x01;
const COMMUNICATION_ERROR: u8 = 0x10;
/// EMCY error codes (Table 21).
pub const ERROR_RESET: u16 = 0x0000;
/// Life guard error or heartbeat error.
pub const HEARTBEAT_ERROR: u16 = 0x8130;

/// The SYNC producer.
#[derive(Clone, Debug, Default)]
pub struct SyncProducer {
    next_us: Option<u64>,
    counter: u8,
}

impl SyncProducer {
    /// (Re)starts from `now_us` as 1005h and 1006h say.
    pub fn configure(&mut self, od: &ObjectDictionary, now_us: u64) {
        let generate = od.unsigned(COB_ID_SYNC, 0) & SYNC_GENERATE != 0;
        let period = od.unsigned(CYCLE_PERIOD, 0);
        self.next_us = (generate && period > 0).then_some(now_us + period);
        self.counter = 0;
    }

    /// At `now_us`: the SYNC message, if one is due.
    pub fn tick(&mut self, od: &ObjectDictionary, now_us: u64) -> Option<CanFrame> {
        let due = self.next_us.filter(|&due| now_us >= due)?;
        self.next_us = Some(due + od.unsigned(CYCLE_PERIOD, 0).max(1));
        let id = (od.unsigned(COB_ID_SYNC, 0) & 0x7FF) as u16;
        let overflow = od.unsigned(COUNTER_OVERFLOW, 0) as u8;
        if overflow < 2 {
            return Some(CanFrame::new(id, &[]));
        }
        self.counter = if self.counter >= overflow {
            1
        } else {
            self.counter + 1
        };
        Some(CanFrame::new(id, &[self.counter]))
    }

    /// When the next SYNC is due.
    pub fn deadline(&self) -> Option<u64> {
        self.next_us
    }
}

/// The EMCY producer and the heartbeat consumer.
#[derive(Clone, Debug, Default)]
pub struct Emergencies {
    /// When EMCY may be sent again (inhibit time).
    inhibited_until_us: u64,
    /// EMCY messages waiting for the inhibit time.
    waiting: Vec<(u16, u8)>,
    /// Per 1016h entry: when its producer's heartbeat is due, and whether it timed out.
    watched: Vec<Watch>,
    /// The EMCY COB-ID without 1014h.
    default_cob_id: u16,
}

#[derive(Clone, Copy, Debug, Default)]
struct Watch {
    node: u8,
    time_ms: u64,
    due_us: Option<u64>,
    lost: bool,
}

impl Emergencies {
    /// Reads 1016h again for node `node_id` (after a reset or a write): nothing is watched until
    /// its first heartbeat.
    pub fn configure(&mut self, od: &ObjectDictionary, node_id: u8) {
        self.default_cob_id = default_emcy_cob_id(node_id);
        let count = od.unsigned(CONSUMER_HEARTBEAT, 0);
        self.watched = (1..=count)
            .map(|sub| od.unsigned(CONSUMER_HEARTBEAT, sub as u8))
            .map(|entry| Watch {
                node: (entry >> 16) as u8,
                time_ms: entry & 0xFFFF,
                due_us: None,
                lost: false,
            })
            .filter(|w| w.node != 0 && w.time_ms > 0)
            .collect();
    }

    /// A heartbeat (or boot-up) of some node at `now_us`; what to send (an error reset).
    pub fn heartbeat(&mut self, od: &mut ObjectDictionary, id: u16, now_us: u64) -> Vec<CanFrame> {
        let mut back = false;
        for watch in &mut self.watched {
            if HEARTBEAT_BASE + u16::from(watch.node) == id {
                watch.due_us = Some(now_us + watch.time_ms * 1000);
                back |= std::mem::take(&mut watch.lost);
            }
        }
        if !back || self.watched.iter().any(|w| w.lost) {
            return Vec::new();
        }
        self.communication_recovered(od, now_us)
    }

    /// A communication error (a lost heartbeat, life guarding): the error register's
    /// communication and generic bits, EMCY 8130h.
    pub fn communication_error(&mut self, od: &mut ObjectDictionary, now_us: u64) -> Vec<CanFrame> {
        let register = od.unsigned(ERROR_REGISTER, 0) as u8 | COMMUNICATION_ERROR | GENERIC_ERROR;
        od.set(ERROR_REGISTER, 0, &[register]);
        self.emcy(od, HEARTBEAT_ERROR, now_us)
    }

    /// The communication error is over: the bits cleared, EMCY 0000h (error reset).
    pub fn communication_recovered(
        &mut self,
        od: &mut ObjectDictionary,
        now_us: u64,
    ) -> Vec<CanFrame> {
        let register =
            od.unsigned(ERROR_REGISTER, 0) as u8 & !(COMMUNICATION_ERROR | GENERIC_ERROR);
        od.set(ERROR_REGISTER, 0, &[register]);
        self.emcy(od, ERROR_RESET, now_us)
    }

    /// At `now_us`: heartbeat events and EMCY messages whose inhibit time passed.
    pub fn tick(&mut self, od: &mut ObjectDictionary, now_us: u64) -> Vec<CanFrame> {
        let mut out = Vec::new();
        for k in 0..self.watched.len() {
            let watch = &mut self.watched[k];
            if watch.due_us.is_none_or(|due| now_us < due) {
                continue;
            }
            watch.due_us = None;
            watch.lost = true;
            out.extend(self.communication_error(od, now_us));
        }
        if now_us >= self.inhibited_until_us && !self.waiting.is_empty() {
            let (code, register) = self.waiting.remove(0);
            out.push(self.send(od, code, register, now_us));
        }
        out
    }

    /// Reports `code` with the current error register: now, or once the inhibit time passed.
    fn emcy(&mut self, od: &mut ObjectDictionary, code: u16, now_us: u64) -> Vec<CanFrame> {
        let register = od.unsigned(ERROR_REGISTER, 0) as u8;
        record_error(od, code);
        if now_us < self.inhibited_until_us {
            self.waiting.push((code, register));
            return Vec::new();
        }
        vec![self.send(od, code, register, now_us)]
    }

    fn send(&mut self, od: &ObjectDictionary, code: u16, register: u8, now_us: u64) -> CanFrame {
        self.inhibited_until_us = now_us + od.unsigned(EMCY_INHIBIT, 0) * 100;
        let id = match od.entry(COB_ID_EMCY, 0) {
            Ok(_) => (od.unsigned(COB_ID_EMCY, 0) & 0x7FF) as u16,
            Err(_) => self.default_cob_id,
        };
        let [c0, c1] = code.to_le_bytes();
        CanFrame::new(id, &[c0, c1, register, 0, 0, 0, 0, 0])
    }

    /// When a watched heartbeat or a waiting EMCY is due.
    pub fn deadline(&self) -> Option<u64> {
        let waiting = (!self.waiting.is_empty()).then_some(self.inhibited_until_us);
        self.watched
            .iter()
            .filter_map(|w| w.due_us)
            .chain(waiting)
            .min()
    }
}

/// Keeps `code` in the pre-defined error field, newest first (error resets are not kept).
fn record_error(od: &mut ObjectDictionary, code: u16) {
    let Ok(field) = od.entry(ERROR_FIELD, 0) else {
        return;
    };
    if code == ERROR_RESET || field.data_type.size() != Some(1) {
        return;
    }
    let slots = (1..=u8::MAX)
        .take_while(|&sub| od.entry(ERROR_FIELD, sub).is_ok())
        .count() as u8;
    let count = (od.unsigned(ERROR_FIELD, 0) as u8)
        .saturating_add(1)
        .min(slots);
    for sub in (2..=count).rev() {
        let older = od.unsigned(ERROR_FIELD, sub - 1) as u32;
        od.set(ERROR_FIELD, sub, &older.to_le_bytes());
    }
    od.set(ERROR_FIELD, 1, &u32::from(code).to_le_bytes());
    od.set(ERROR_FIELD, 0, &[count]);
}

/// Whether `id` is the EMCY or heartbeat function code of some node (not of `own`).
pub fn is_heartbeat(id: u16, own: u8) -> bool {
    id & !0x7F == HEARTBEAT_BASE && id != HEARTBEAT_BASE + u16::from(own) && id != HEARTBEAT_BASE
}

/// The default COB-ID EMCY of node `node_id` (80h + node-ID).
fn default_emcy_cob_id(node_id: u8) -> u16 {
    EMCY_BASE + u16::from(node_id)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eds;
    use std::path::Path;

    const EDS: &str = "\
[MandatoryObjects]
SupportedObjects=8
1=0x1001
2=0x1003
3=0x1005
4=0x1006
5=0x1014
6=0x1015
7=0x1016
8=0x1019
[1001]
ParameterName=Error register
DataType=0x0005
AccessType=ro
DefaultValue=0
[1003]
ParameterName=Pre-defined error field
ObjectType=0x8
[1003sub0]
ParameterName=n
DataType=0x0005
AccessType=rw
DefaultValue=0
[1003sub1]
ParameterName=1
DataType=0x0007
AccessType=ro
DefaultValue=0
[1003sub2]
ParameterName=2
DataType=0x0007
AccessType=ro
DefaultValue=0
[1005]
ParameterName=COB-ID SYNC
DataType=0x0007
AccessType=rw
DefaultValue=0x40000080
[1006]
ParameterName=Period
DataType=0x0007
AccessType=rw
DefaultValue=1000
[1014]
ParameterName=COB-ID EMCY
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x80
[1015]
ParameterName=Inhibit
DataType=0x0006
AccessType=rw
DefaultValue=10
[1016]
ParameterName=Consumer heartbeat time
ObjectType=0x8
[1016sub0]
ParameterName=n
DataType=0x0005
AccessType=const
DefaultValue=1
[1016sub1]
ParameterName=1
DataType=0x0007
AccessType=rw
DefaultValue=0x00050064
[1019]
ParameterName=Overflow
DataType=0x0005
AccessType=rw
DefaultValue=3
";

    fn od() -> ObjectDictionary {
        eds::parse(EDS, Path::new("t.eds"), 2).unwrap()
    }

    #[test]
    fn a_sync_producer_counts_1_to_the_overflow_value_every_period() {
        let od = od();
        let mut sync = SyncProducer::default();
        sync.configure(&od, 0);
        assert_eq!(sync.deadline(), Some(1000));
        assert_eq!(sync.tick(&od, 999), None);
        let counters: Vec<Vec<u8>> = (1..=4)
            .map(|k| sync.tick(&od, k * 1000).unwrap().data)
            .collect();
        assert_eq!(counters, [[1], [2], [3], [1]]);
    }

    #[test]
    fn a_missing_heartbeat_is_emcy_8130_and_its_return_an_error_reset() {
        let mut od = od();
        let mut emcy = Emergencies::default();
        emcy.configure(&od, 2);
        assert!(
            emcy.tick(&mut od, 1_000_000).is_empty(),
            "not watched before its first heartbeat"
        );
        assert!(emcy.heartbeat(&mut od, 0x705, 0).is_empty());
        assert!(emcy.tick(&mut od, 99_999).is_empty());
        // 100 ms later: EMCY 8130h on 80h + 2 with the register's communication and generic bits.
        assert_eq!(
            emcy.tick(&mut od, 100_000),
            [CanFrame::new(0x082, &[0x30, 0x81, 0x11, 0, 0, 0, 0, 0])]
        );
        assert_eq!(od.unsigned(0x1001, 0), 0x11);
        assert_eq!(
            (od.unsigned(0x1003, 0), od.unsigned(0x1003, 1)),
            (1, 0x8130)
        );
        // Back within the inhibit time (1 ms): the error reset waits for it.
        assert!(emcy.heartbeat(&mut od, 0x705, 100_500).is_empty());
        assert_eq!(od.unsigned(0x1001, 0), 0);
        assert_eq!(emcy.deadline(), Some(101_000));
        assert_eq!(
            emcy.tick(&mut od, 101_000),
            [CanFrame::new(0x082, &[0, 0, 0, 0, 0, 0, 0, 0])]
        );
    }

    #[test]
    fn heartbeats_of_others_are_told_from_our_own_and_from_nmt() {
        assert!(is_heartbeat(0x705, 2));
        assert!(!is_heartbeat(0x702, 2));
        assert!(!is_heartbeat(0x700, 2));
        assert!(!is_heartbeat(0x185, 2));
        assert_eq!(default_emcy_cob_id(2), 0x082);
    }
}
