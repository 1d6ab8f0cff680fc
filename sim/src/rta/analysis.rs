//! The two response-time analyses of a [`MessageSet`], message by message in priority order.
//!
//! Notation (all in ticks): C transmission time (worst-case frame plus intermission), T period,
//! J release jitter, D deadline, τ one bit time; hp(m) are the messages of higher priority than m,
//! lp(m) those of lower priority, hep(m) = hp(m) ∪ {m}.
//!
//! * **Classic** (Tindell et al. 1994, as taught): blocking `B = max lp C − τ` (0 without lower
//!   priority messages); queuing delay `w = B + Σ_hp ⌈(w + J_k + τ)/T_k⌉·C_k`, iterated from
//!   `w = 0` to the least fixed point; `R = J + w + C`. It looks at the first instance only.
//! * **Corrected** (Davis, Burns, Bril, Lukkien 2007): blocking `B = max lp C`; the level-m busy
//!   period `t = B + Σ_hep ⌈(t + J_k)/T_k⌉·C_k` from `t = C`; its `Q = ⌈(t + J)/T⌉` instances
//!   q = 0..Q each get `w(q) = B + q·C + Σ_hp ⌈(w(q) + J_k + τ)/T_k⌉·C_k` and
//!   `R(q) = J + w(q) − q·T + C`; `R = max_q R(q)`.
//!
//! Both recurrences only converge when the utilisation of the messages they sum is below 1; the
//! analysis checks that first and reports [`Divergence`] instead of iterating.

use super::message_set::{utilisation, Message, MessageSet};
use super::Ticks;

/// Fixed-point iterations after which a recurrence is declared divergent even though the
/// utilisation is below 1 (it is then so close to 1 that the busy period is astronomically long).
pub const MAX_ITERATIONS: u64 = 10_000_000;

/// Longest busy period or queuing delay computed; beyond it a recurrence counts as divergent.
/// Far above any message set's times (these are at most [`super::message_set::MAX_TIME`]), far
/// below the `u64` overflow of the ceiling terms.
pub const LONGEST_BUSY_PERIOD: Ticks = 1 << 60;

/// A bounded worst case of one message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Response {
    /// Blocking by one lower-priority frame already on the bus.
    pub blocking: Ticks,
    /// Worst queuing delay, from queuing to the start of transmission: `R − J − C`.
    pub queuing: Ticks,
    /// Worst-case response time from the initiating event: jitter + queuing + transmission.
    pub response: Ticks,
}

/// The corrected analysis of one message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Corrected {
    /// The worst instance's figures.
    pub worst: Response,
    /// Length of the level-m busy period.
    pub busy_period: Ticks,
    /// Instances of the message in the busy period (Q).
    pub instances: u64,
    /// Which instance (0-based) has the longest response.
    pub worst_instance: u64,
    /// Response of the first instance, R(0).
    pub first_response: Ticks,
}

/// A recurrence that has no finite solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Divergence {
    /// Utilisation of the messages the recurrence sums (at least 1, or just below with
    /// [`MAX_ITERATIONS`] reached).
    pub utilisation: f64,
}

/// Both analyses of one message.
#[derive(Clone, Debug, PartialEq)]
pub struct MessageBounds {
    /// Classic analysis.
    pub classic: Result<Response, Divergence>,
    /// Corrected analysis.
    pub corrected: Result<Corrected, Divergence>,
}

/// The analyses of a whole set.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    /// One entry per message, in the set's (priority) order.
    pub messages: Vec<MessageBounds>,
    /// Bus utilisation Σ C/T.
    pub utilisation: f64,
}

impl Analysis {
    /// Runs both analyses on every message of `set`.
    pub fn of(set: &MessageSet) -> Analysis {
        let tau = set.time_base.bit_ticks();
        let messages = (0..set.messages.len())
            .map(|i| MessageBounds {
                classic: classic(&set.messages, i, tau),
                corrected: corrected(&set.messages, i, tau),
            })
            .collect();
        Analysis {
            messages,
            utilisation: set.utilisation(),
        }
    }
}

/// Classic analysis of message `i` of `messages` (priority order).
pub fn classic(messages: &[Message], i: usize, tau: Ticks) -> Result<Response, Divergence> {
    let m = &messages[i];
    let hp = &messages[..i];
    let blocking = longest_lower(messages, i).map_or(0, |c| c.saturating_sub(tau));
    let queuing = fixed_point(0, hp, |w| blocking + interference(hp, w + tau))?;
    Ok(Response {
        blocking,
        queuing,
        response: m.jitter + queuing + m.transmission,
    })
}

/// Corrected analysis of message `i` of `messages` (priority order).
pub fn corrected(messages: &[Message], i: usize, tau: Ticks) -> Result<Corrected, Divergence> {
    let m = &messages[i];
    let (hp, hep) = (&messages[..i], &messages[..=i]);
    let blocking = longest_lower(messages, i).unwrap_or(0);
    let busy_period = fixed_point(m.transmission, hep, |t| blocking + interference(hep, t))?;
    let instances = (busy_period + m.jitter).div_ceil(m.period);
    let mut worst: Option<(Ticks, u64)> = None;
    let mut first_response = 0;
    let mut w = blocking;
    for q in 0..instances {
        let own = blocking + q * m.transmission;
        w = fixed_point(w.max(own), hp, |w| own + interference(hp, w + tau))?;
        // R(q) ≥ C for q = 0, so a negative R(q) of a later instance never matters.
        let response = (m.jitter + w + m.transmission).saturating_sub(q * m.period);
        if q == 0 {
            first_response = response;
        }
        if worst.is_none_or(|(r, _)| response > r) {
            worst = Some((response, q));
        }
    }
    let (response, worst_instance) = worst.expect("a busy period holds at least one instance");
    Ok(Corrected {
        worst: Response {
            blocking,
            queuing: response - m.jitter - m.transmission,
            response,
        },
        busy_period,
        instances,
        worst_instance,
        first_response,
    })
}

/// The longest C of the messages after `i`, if any.
fn longest_lower(messages: &[Message], i: usize) -> Option<Ticks> {
    messages[i + 1..].iter().map(|m| m.transmission).max()
}

/// `Σ ⌈(window + J_k)/T_k⌉·C_k` over `messages`: their transmissions released within `window`
/// after a critical instant, the first release of each delayed by its full jitter.
fn interference(messages: &[Message], window: Ticks) -> Ticks {
    messages
        .iter()
        .map(|k| (window + k.jitter).div_ceil(k.period) * k.transmission)
        .sum()
}

/// The least fixed point at or above `start` of the non-decreasing `step`, whose growth is the
/// interference of `sums`. Refuses without iterating when the utilisation of `sums` is 1 or more,
/// and gives up after [`MAX_ITERATIONS`] or beyond [`LONGEST_BUSY_PERIOD`].
fn fixed_point(
    start: Ticks,
    sums: &[Message],
    step: impl Fn(Ticks) -> Ticks,
) -> Result<Ticks, Divergence> {
    let divergence = Divergence {
        utilisation: utilisation(sums),
    };
    if divergence.utilisation >= 1.0 {
        return Err(divergence);
    }
    let mut x = start;
    for _ in 0..MAX_ITERATIONS {
        let next = step(x);
        if next <= x {
            return Ok(x);
        }
        if next > LONGEST_BUSY_PERIOD {
            return Err(divergence);
        }
        x = next;
    }
    Err(divergence)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rta::message_set::TimeBase;
    use golden::frame::Id;

    /// Abstract-unit messages (τ = 1) from (C, T) pairs in priority order.
    fn set(messages: &[(Ticks, Ticks)]) -> MessageSet {
        set_with_jitter(&messages.iter().map(|&(c, t)| (c, t, 0)).collect::<Vec<_>>())
    }

    fn set_with_jitter(messages: &[(Ticks, Ticks, Ticks)]) -> MessageSet {
        MessageSet {
            source: "test".into(),
            title: None,
            time_base: TimeBase::Abstract,
            messages: messages
                .iter()
                .enumerate()
                .map(|(i, &(c, t, j))| Message {
                    name: format!("m{}", i + 1),
                    id: Id::Standard(i as u16),
                    node: None,
                    dlc: None,
                    transmission: c,
                    period: t,
                    jitter: j,
                    deadline: t,
                    line: i + 1,
                })
                .collect(),
        }
    }

    fn classic_queuing(set: &MessageSet) -> Vec<Ticks> {
        Analysis::of(set)
            .messages
            .iter()
            .map(|b| b.classic.unwrap().queuing)
            .collect()
    }

    #[test]
    fn classic_worked_examples() {
        assert_eq!(classic_queuing(&set(&[(1, 3), (1, 6), (3, 10)])), [2, 4, 2]);
        assert_eq!(classic_queuing(&set(&[(1, 3), (1, 6), (4, 10)])), [3, 5, 2]);
    }

    #[test]
    fn corrected_finds_the_later_instance_the_classic_analysis_misses() {
        // Davis et al. 2007 in µs at 125 kbit/s (τ = 8): C = 1000, T = 2500, 3500, 3500.
        let davis = set(&[(1000, 2500), (1000, 3500), (1000, 3500)]);
        let tau = 8;
        let c = classic(&davis.messages, 2, tau).unwrap();
        let d = corrected(&davis.messages, 2, tau).unwrap();
        assert_eq!(c.response, 3000);
        assert_eq!(d.first_response, 3000);
        assert_eq!(
            (d.worst.response, d.worst_instance, d.instances),
            (3500, 1, 2)
        );
        assert_eq!(d.busy_period, 7000);
    }

    #[test]
    fn jitter_delays_the_own_response_and_advances_higher_releases() {
        // m1 (C 1, T 4, J 2) released late at the critical instant, then again 2 units later.
        let s = set_with_jitter(&[(1, 4, 2), (2, 10, 0)]);
        let m1 = classic(&s.messages, 0, 1).unwrap();
        assert_eq!((m1.blocking, m1.queuing, m1.response), (1, 1, 4));
        // m2: w = ⌈(w + 2 + 1)/4⌉: w = 1 → 1 → R = 1 + 2 = 3.
        assert_eq!(classic(&s.messages, 1, 1).unwrap().response, 3);
    }

    #[test]
    fn utilisation_of_one_or_more_diverges_without_iterating() {
        let s = set(&[(2, 4), (2, 4), (1, 10)]);
        let a = Analysis::of(&s);
        assert!(a.messages[0].classic.is_ok());
        assert!(
            a.messages[1].classic.is_ok(),
            "hp utilisation 0.5 converges"
        );
        let d = a.messages[1].corrected.unwrap_err();
        assert_eq!(d.utilisation, 1.0);
        assert!(a.messages[2].classic.unwrap_err().utilisation >= 1.0);
        assert!(a.messages[2].corrected.is_err());
    }

    #[test]
    fn a_busy_period_close_to_full_utilisation_still_converges() {
        let s = set(&[(999, 1000), (1000, 1_000_000_000)]);
        let d = corrected(&s.messages, 1, 1).unwrap();
        // t = 999·⌈t/1000⌉ + 1000 first holds at t = 1 000 000, after about 1000 iterations.
        assert_eq!(d.busy_period, 1_000_000);
    }
}
