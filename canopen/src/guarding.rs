//! Node guarding and life guarding (CiA 301 7.2.8.3.1): the NMT master asks with a remote frame on
//! 700h + node-ID; the device answers one byte, its state (bits 6..0) and a toggle bit (bit 7)
//! that starts at 0 and alternates with every answer. With a guard time (100Ch, ms) and a life
//! time factor (100Dh) that are both set, a device that gets no request for their product after
//! the first one has a life guarding event: EMCY 8130h with the error register's communication
//! bit; the next request ends it (error reset). A device whose heartbeat producer time (1017h) is
//! set uses the heartbeat instead and does not answer guarding requests.

use crate::od::ObjectDictionary;

/// Guard time (ms) and life time factor.
const GUARD_TIME: u16 = 0x100C;
const LIFE_TIME_FACTOR: u16 = 0x100D;
/// The toggle bit of an answer.
const TOGGLE: u8 = 0x80;

/// What a guarded device keeps.
#[derive(Clone, Debug, Default)]
pub struct Guarding {
    toggle: bool,
    life_deadline_us: Option<u64>,
    lost: bool,
}

/// What a guarding request or the time did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuardEvent {
    /// Nothing to report.
    None,
    /// The life time passed without a request.
    LifeGuardingLost,
    /// A request came after the life time had passed.
    Resumed,
}

impl Guarding {
    /// After boot-up or reset communication: the toggle bit starts at 0 and nothing is guarded.
    pub fn reset(&mut self) {
        *self = Guarding::default();
    }

    /// A guarding request at `now_us` for a device in `state_code`: the answer byte, and whether
    /// it ends a life guarding event.
    pub fn request(
        &mut self,
        od: &ObjectDictionary,
        state_code: u8,
        now_us: u64,
    ) -> (u8, GuardEvent) {
        let answer = if self.toggle { TOGGLE } else { 0 } | state_code;
        self.toggle = !self.toggle;
        let life_ms = od.unsigned(GUARD_TIME, 0) * od.unsigned(LIFE_TIME_FACTOR, 0);
        self.life_deadline_us = (life_ms > 0).then_some(now_us + life_ms * 1000);
        let event = if std::mem::take(&mut self.lost) {
            GuardEvent::Resumed
        } else {
            GuardEvent::None
        };
        (answer, event)
    }

    /// At `now_us`: whether the life time just ran out.
    pub fn tick(&mut self, now_us: u64) -> GuardEvent {
        if self.life_deadline_us.is_none_or(|due| now_us < due) {
            return GuardEvent::None;
        }
        self.life_deadline_us = None;
        self.lost = true;
        GuardEvent::LifeGuardingLost
    }

    /// When the life time runs out.
    pub fn deadline(&self) -> Option<u64> {
        self.life_deadline_us
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
1=0x100C
2=0x100D
[100C]
ParameterName=Guard time
DataType=0x0006
AccessType=rw
DefaultValue=10
[100D]
ParameterName=Life time factor
DataType=0x0005
AccessType=rw
DefaultValue=3
";

    #[test]
    fn answers_toggle_from_0_and_a_silent_master_is_a_life_guarding_event() {
        let od = eds::parse(EDS, Path::new("t.eds"), 1).unwrap();
        let mut guarding = Guarding::default();
        assert_eq!(
            guarding.tick(1_000_000),
            GuardEvent::None,
            "not guarded before a request"
        );
        assert_eq!(guarding.request(&od, 0x7F, 0), (0x7F, GuardEvent::None));
        assert_eq!(guarding.request(&od, 0x05, 5_000), (0x85, GuardEvent::None));
        // 10 ms x 3 after the last request.
        assert_eq!(guarding.deadline(), Some(35_000));
        assert_eq!(guarding.tick(34_999), GuardEvent::None);
        assert_eq!(guarding.tick(35_000), GuardEvent::LifeGuardingLost);
        assert_eq!(
            guarding.request(&od, 0x05, 40_000),
            (0x05, GuardEvent::Resumed)
        );
        guarding.reset();
        assert_eq!(
            guarding.request(&od, 0x7F, 50_000).0,
            0x7F,
            "toggle 0 again"
        );
    }
}
