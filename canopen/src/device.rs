//! A CANopen device: its node-ID, object dictionary, NMT state, SDO server, heartbeat producer
//! and PDOs, driven by the frames it receives and the time that passes.
//!
//! COB-IDs of the predefined connection set (CiA 301 7.3.5, Table 79): NMT 000h, SDO requests
//! 600h + node-ID and responses 580h + node-ID, boot-up and heartbeat 700h + node-ID. At start
//! and after a reset the device sends its boot-up message (one byte 00h) and enters
//! pre-operational (7.3.2.2.1); it then sends a heartbeat with its state every 1017h
//! milliseconds when 1017h is not 0 (7.2.8.3.2.1).

use crate::error_control::{is_heartbeat, Emergencies, SyncProducer};
use crate::guarding::{GuardEvent, Guarding};
use crate::nmt::{NmtCommand, NmtState};
use crate::od::ObjectDictionary;
use crate::pdo::{receive_rpdo, Tpdos};
use crate::sdo::SdoServer;
use crate::time_stamp::{TimeOfDay, COB_ID_TIME, TIME_CONSUMER};
use crate::CanFrame;

/// COB-ID of NMT commands.
pub const NMT_COB_ID: u16 = 0x000;
/// Function codes of the predefined connection set, added to the node-ID.
pub const SDO_RESPONSE: u16 = 0x580;
/// SDO requests to the device.
pub const SDO_REQUEST: u16 = 0x600;
/// Boot-up, heartbeat and guarding.
pub const ERROR_CONTROL: u16 = 0x700;
/// Producer heartbeat time (ms, UNSIGNED16).
pub const PRODUCER_HEARTBEAT_TIME: u16 = 0x1017;
/// COB-ID SYNC (bits 10..0), and the SYNC COB-ID without it (7.5.2.5).
pub const COB_ID_SYNC: u16 = 0x1005;
/// Communication cycle period (µs).
pub const COMMUNICATION_CYCLE_PERIOD: u16 = 0x1006;
/// Consumer heartbeat time.
pub const CONSUMER_HEARTBEAT_TIME: u16 = 0x1016;
const DEFAULT_SYNC_COB_ID: u16 = 0x080;
/// The communication profile area, reset by reset communication.
const COMMUNICATION_AREA: std::ops::RangeInclusive<u16> = 0x1000..=0x1FFF;
/// Microseconds per millisecond.
const US_PER_MS: u64 = 1000;

/// A device on the bus.
pub struct Device {
    node_id: u8,
    defaults: ObjectDictionary,
    od: ObjectDictionary,
    state: NmtState,
    sdo: SdoServer,
    next_heartbeat_us: Option<u64>,
    tpdos: Tpdos,
    sync: SyncProducer,
    emergencies: Emergencies,
    guarding: Guarding,
    /// The last TIME consumed and when it came.
    time: Option<(TimeOfDay, u64)>,
}

impl Device {
    /// A device with `node_id` (1 to 127, CiA 301 7.3.1) and object dictionary `od` (its values are
    /// the defaults resets go back to), in initialisation until [`Device::start`].
    pub fn new(node_id: u8, od: ObjectDictionary) -> Result<Device, String> {
        if !(1..=127).contains(&node_id) {
            return Err(format!("node-ID {node_id} is out of range 1..=127"));
        }
        Ok(Device {
            node_id,
            defaults: od.clone(),
            od,
            state: NmtState::Initialisation,
            sdo: SdoServer::default(),
            next_heartbeat_us: None,
            tpdos: Tpdos::default(),
            sync: SyncProducer::default(),
            emergencies: Emergencies::default(),
            guarding: Guarding::default(),
            time: None,
        })
    }

    /// Its node-ID.
    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    /// Its NMT state.
    pub fn state(&self) -> NmtState {
        self.state
    }

    /// Its object dictionary.
    pub fn od(&self) -> &ObjectDictionary {
        &self.od
    }

    /// Its time of day at `now_us`: the last TIME message it consumed plus the time since, if one
    /// came.
    pub fn time_of_day(&self, now_us: u64) -> Option<TimeOfDay> {
        self.time
            .map(|(time, at_us)| time.plus_us(now_us.saturating_sub(at_us)))
    }

    /// Power-on at `now_us`: the boot-up message; then pre-operational.
    pub fn start(&mut self, now_us: u64) -> Vec<CanFrame> {
        self.boot(now_us)
    }

    fn boot(&mut self, now_us: u64) -> Vec<CanFrame> {
        self.sdo = SdoServer::default();
        self.guarding.reset();
        self.state = NmtState::PreOperational;
        self.configure(now_us);
        vec![CanFrame::new(
            ERROR_CONTROL + u16::from(self.node_id),
            &[NmtState::Initialisation.code()],
        )]
    }

    /// Starts the heartbeat producer, the SYNC producer and the heartbeat consumer as the
    /// dictionary says.
    fn configure(&mut self, now_us: u64) {
        self.schedule_heartbeat(now_us);
        self.sync.configure(&self.od, now_us);
        self.emergencies.configure(&self.od, self.node_id);
    }

    /// What the timers depend on: 1017h, 1005h, 1006h and 1016h.
    fn timer_settings(&self) -> Vec<u64> {
        let consumer = (0..=self.od.unsigned(CONSUMER_HEARTBEAT_TIME, 0) as u8)
            .map(|sub| self.od.unsigned(CONSUMER_HEARTBEAT_TIME, sub));
        [
            PRODUCER_HEARTBEAT_TIME,
            COB_ID_SYNC,
            COMMUNICATION_CYCLE_PERIOD,
        ]
        .iter()
        .map(|&index| self.od.unsigned(index, 0))
        .chain(consumer)
        .collect()
    }

    fn schedule_heartbeat(&mut self, now_us: u64) {
        let period_ms = self.od.unsigned(PRODUCER_HEARTBEAT_TIME, 0);
        self.next_heartbeat_us = (period_ms > 0).then(|| now_us + period_ms * US_PER_MS);
    }

    /// The frame `frame` arrives at `now_us`; what the device sends in answer.
    pub fn receive(&mut self, frame: &CanFrame, now_us: u64) -> Vec<CanFrame> {
        if self.state == NmtState::Initialisation {
            return Vec::new();
        }
        if frame.remote {
            if self.state == NmtState::Operational {
                if let Some(tpdo) = self.tpdos.rtr(&self.od, frame.id, now_us) {
                    return vec![tpdo];
                }
            }
            return self.guarding_request(frame, now_us);
        }
        if frame.id == NMT_COB_ID {
            return self.nmt(&frame.data, now_us);
        }
        if self.state == NmtState::Operational {
            if frame.id == self.sync_cob_id() {
                return self
                    .tpdos
                    .sync(&self.od, frame.data.first().copied(), now_us);
            }
            if receive_rpdo(&mut self.od, frame) {
                return Vec::new();
            }
        }
        if self.consumes_time(frame.id) {
            if let Some(time) = TimeOfDay::decode(&frame.data) {
                self.time = Some((time, now_us));
            }
            return Vec::new();
        }
        if is_heartbeat(frame.id, self.node_id) {
            return self.emergencies.heartbeat(&mut self.od, frame.id, now_us);
        }
        if frame.id == SDO_REQUEST + u16::from(self.node_id) && self.state.serves_sdo() {
            let settings = self.timer_settings();
            let answer = self.sdo.request(&mut self.od, &frame.data, now_us);
            if self.timer_settings() != settings {
                self.configure(now_us);
            }
            return answer
                .iter()
                .map(|data| CanFrame::new(SDO_RESPONSE + u16::from(self.node_id), data))
                .collect();
        }
        Vec::new()
    }

    /// A remote frame: a node guarding request, if it is on our 700h + node-ID and the heartbeat
    /// is off.
    fn guarding_request(&mut self, frame: &CanFrame, now_us: u64) -> Vec<CanFrame> {
        let ours = ERROR_CONTROL + u16::from(self.node_id);
        if frame.id != ours || self.od.unsigned(PRODUCER_HEARTBEAT_TIME, 0) != 0 {
            return Vec::new();
        }
        let (answer, event) = self.guarding.request(&self.od, self.state.code(), now_us);
        let mut out = vec![CanFrame::new(ours, &[answer])];
        if event == GuardEvent::Resumed {
            out.extend(
                self.emergencies
                    .communication_recovered(&mut self.od, now_us),
            );
        }
        out
    }

    fn nmt(&mut self, data: &[u8], now_us: u64) -> Vec<CanFrame> {
        // 7.2.8.3.1: two bytes, the command specifier and the node-ID (0: all nodes).
        let [cs, node] = data else {
            return Vec::new();
        };
        if *node != 0 && *node != self.node_id {
            return Vec::new();
        }
        let Some(command) = NmtCommand::from_specifier(*cs) else {
            return Vec::new();
        };
        match command {
            NmtCommand::ResetNode => {
                self.od = self.defaults.clone();
                self.boot(now_us)
            }
            NmtCommand::ResetCommunication => {
                for (index, object) in &self.defaults.objects {
                    if COMMUNICATION_AREA.contains(index) {
                        self.od.objects.insert(*index, object.clone());
                    }
                }
                self.boot(now_us)
            }
            _ => {
                let next = command.next_state();
                if next == NmtState::Operational && self.state != NmtState::Operational {
                    self.tpdos.start(&self.od, now_us);
                }
                self.state = next;
                Vec::new()
            }
        }
    }

    /// Whether `id` carries TIME messages this device consumes: 1012h has the consumer bit and
    /// this COB-ID, and TIME is a pre-operational and operational service (Table 82).
    fn consumes_time(&self, id: u16) -> bool {
        let Ok(_) = self.od.entry(COB_ID_TIME, 0) else {
            return false;
        };
        let cob_id = self.od.unsigned(COB_ID_TIME, 0);
        self.state.serves_sdo() && cob_id & TIME_CONSUMER != 0 && (cob_id & 0x7FF) as u16 == id
    }

    /// The COB-ID SYNC messages come on.
    fn sync_cob_id(&self) -> u16 {
        match self.od.entry(COB_ID_SYNC, 0) {
            Ok(_) => (self.od.unsigned(COB_ID_SYNC, 0) & 0x7FF) as u16,
            Err(_) => DEFAULT_SYNC_COB_ID,
        }
    }

    /// The time is `now_us`: what falls due (heartbeats, SDO timeouts, event-driven TPDOs).
    pub fn tick(&mut self, now_us: u64) -> Vec<CanFrame> {
        let mut out = Vec::new();
        if self.guarding.tick(now_us) == GuardEvent::LifeGuardingLost {
            out.extend(self.emergencies.communication_error(&mut self.od, now_us));
        }
        if self.state == NmtState::Operational {
            out.extend(self.tpdos.tick(&self.od, now_us));
        }
        // SYNC and EMCY are pre-operational and operational services (Table 82); the producer's
        // own synchronous TPDOs follow its SYNC, as it receives no frame of its own.
        if self.state.serves_sdo() {
            if let Some(sync) = self.sync.tick(&self.od, now_us) {
                if self.state == NmtState::Operational {
                    let counter = sync.data.first().copied();
                    out.push(sync);
                    out.extend(self.tpdos.sync(&self.od, counter, now_us));
                } else {
                    out.push(sync);
                }
            }
            out.extend(self.emergencies.tick(&mut self.od, now_us));
        }
        if let Some(abort) = self.sdo.check_timeout(now_us) {
            out.push(CanFrame::new(
                SDO_RESPONSE + u16::from(self.node_id),
                &abort,
            ));
        }
        if self.next_heartbeat_us.is_some_and(|due| now_us >= due) {
            out.push(CanFrame::new(
                ERROR_CONTROL + u16::from(self.node_id),
                &[self.state.code()],
            ));
            let period_us = self.od.unsigned(PRODUCER_HEARTBEAT_TIME, 0) * US_PER_MS;
            self.next_heartbeat_us = self.next_heartbeat_us.map(|due| due + period_us);
        }
        out
    }

    /// When something falls due next, if anything will.
    pub fn next_deadline(&self) -> Option<u64> {
        let tpdo = self
            .tpdos
            .deadline()
            .filter(|_| self.state == NmtState::Operational);
        let producers = [self.sync.deadline(), self.emergencies.deadline()]
            .into_iter()
            .filter(|_| self.state.serves_sdo());
        [
            self.next_heartbeat_us,
            self.sdo.deadline(),
            tpdo,
            self.guarding.deadline(),
        ]
        .into_iter()
        .chain(producers)
        .flatten()
        .min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eds;
    use std::path::Path;

    const EDS: &str = "\
[MandatoryObjects]
SupportedObjects=2
1=0x1000
2=0x1017
[1000]
ParameterName=Device type
DataType=0x0007
AccessType=ro
DefaultValue=0x00000191
[1017]
ParameterName=Producer heartbeat time
DataType=0x0006
AccessType=rw
DefaultValue=100
";

    fn device() -> Device {
        Device::new(3, eds::parse(EDS, Path::new("t.eds"), 3).unwrap()).unwrap()
    }

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(id, data)
    }

    #[test]
    fn boot_up_then_heartbeats_with_the_state_every_1017h_ms() {
        let mut d = device();
        assert_eq!(d.start(0), [frame(0x703, &[0x00])]);
        assert_eq!(d.state(), NmtState::PreOperational);
        assert_eq!(d.next_deadline(), Some(100_000));
        assert!(d.tick(99_999).is_empty());
        assert_eq!(d.tick(100_000), [frame(0x703, &[0x7F])]);
        d.receive(&frame(0x000, &[0x01, 3]), 150_000);
        assert_eq!(d.tick(200_000), [frame(0x703, &[0x05])]);
        d.receive(&frame(0x000, &[0x02, 0]), 250_000);
        assert_eq!(d.tick(300_000), [frame(0x703, &[0x04])]);
    }

    #[test]
    fn nmt_commands_for_other_nodes_are_ignored_and_resets_boot_again() {
        let mut d = device();
        d.start(0);
        d.receive(&frame(0x000, &[0x01, 4]), 10);
        assert_eq!(d.state(), NmtState::PreOperational, "for node 4");
        d.receive(&frame(0x000, &[0x01, 3]), 10);
        assert_eq!(d.state(), NmtState::Operational);
        // SDO writes 1017h = 500 ms, then reset communication brings back 100 ms.
        d.receive(&frame(0x603, &[0x2B, 0x17, 0x10, 0, 0xF4, 0x01, 0, 0]), 20);
        assert_eq!(d.od().unsigned(0x1017, 0), 500);
        assert_eq!(
            d.receive(&frame(0x000, &[0x82, 0]), 30),
            [frame(0x703, &[0x00])]
        );
        assert_eq!(d.state(), NmtState::PreOperational);
        assert_eq!(d.od().unsigned(0x1017, 0), 100);
    }

    #[test]
    fn a_stopped_device_answers_no_sdo() {
        let mut d = device();
        d.start(0);
        let read = frame(0x603, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]);
        assert_eq!(
            d.receive(&read, 1),
            [frame(0x583, &[0x43, 0x00, 0x10, 0, 0x91, 0x01, 0, 0])]
        );
        d.receive(&frame(0x000, &[0x02, 3]), 2);
        assert!(d.receive(&read, 3).is_empty());
    }

    #[test]
    fn time_is_consumed_when_1012h_says_so_and_runs_on_with_the_local_clock() {
        let with_time = EDS.replace("SupportedObjects=2\n1=0x1000\n2=0x1017", "SupportedObjects=3\n1=0x1000\n2=0x1017\n3=0x1012")
            + "[1012]\nParameterName=COB-ID TIME\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x80000100\n";
        let od = eds::parse(&with_time, Path::new("t.eds"), 3).unwrap();
        let mut d = Device::new(3, od).unwrap();
        d.start(0);
        let noon = TimeOfDay {
            days: 5844,
            ms: 43_200_000,
        };
        d.receive(&frame(0x100, &noon.encode()), 1_000);
        assert_eq!(d.time_of_day(1_000), Some(noon));
        assert_eq!(
            d.time_of_day(251_000).map(|t| t.to_string()),
            Some("2000-01-01 12:00:00.250".to_string())
        );
        // Bit 31 cleared: TIME messages are no longer consumed.
        d.receive(
            &frame(0x603, &[0x23, 0x12, 0x10, 0, 0x00, 0x01, 0, 0]),
            2_000,
        );
        d.receive(&frame(0x100, &TimeOfDay::Y2000.encode()), 3_000);
        assert_eq!(d.time_of_day(3_000), Some(noon.plus_us(2_000)));
        // A device without 1012h consumes none.
        let mut plain = device();
        plain.start(0);
        plain.receive(&frame(0x100, &noon.encode()), 1_000);
        assert_eq!(plain.time_of_day(1_000), None);
    }

    #[test]
    fn node_ids_outside_1_to_127_are_refused() {
        let od = eds::parse(EDS, Path::new("t.eds"), 1).unwrap();
        assert!(Device::new(0, od.clone()).is_err());
        assert!(Device::new(128, od).is_err());
    }
}
