//! The analysis (and simulation) of a message set as a text table or as CSV.

use super::analysis::{Analysis, Corrected, Divergence, Response};
use super::message_set::{Message, MessageSet, TimeBase};
use super::simulate::{Observation, Simulation};
use super::Ticks;
use golden::frame::encode;

/// A verdict cell: meets its deadline, misses it, or has no finite bound.
fn verdict(response: Option<Ticks>, deadline: Ticks) -> &'static str {
    match response {
        Some(r) if r <= deadline => "yes",
        Some(_) => "no",
        None => "unbounded",
    }
}

/// The text report: a header, one row per message with both analyses, and what stands out.
pub fn format_table(set: &MessageSet, analysis: &Analysis) -> String {
    let base = set.time_base;
    let t = |ticks: Ticks| base.format(ticks);
    let bits = matches!(base, TimeBase::Bitrate(_));
    let mut table = Table::default();
    table.group(0, "");
    table.column("message", Align::Left);
    table.column("id", Align::Right);
    if set.messages.iter().any(|m| m.node.is_some()) {
        table.column("node", Align::Left);
    }
    if bits {
        table.column("dlc", Align::Right);
        table.column("bits", Align::Right);
    }
    for header in ["C", "T", "J", "D"] {
        table.column(header, Align::Right);
    }
    table.group(table.width(), "classic");
    for header in ["B", "w", "R", "ok"] {
        table.column(header, Align::Right);
    }
    table.group(table.width(), "corrected (Davis et al. 2007)");
    for header in ["B", "w", "R", "q/Q", "ok"] {
        table.column(header, Align::Right);
    }
    for (m, bounds) in set.messages.iter().zip(&analysis.messages) {
        let mut row = vec![m.name.clone(), m.id.to_string()];
        if table.has("node") {
            row.push(m.node.clone().unwrap_or_default());
        }
        if bits {
            row.push(m.dlc.unwrap_or(0).to_string());
            row.push((m.transmission / base.bit_ticks()).to_string());
        }
        row.extend([m.transmission, m.period, m.jitter, m.deadline].map(t));
        match &bounds.classic {
            Ok(r) => row.extend([t(r.blocking), t(r.queuing), t(r.response)]),
            Err(_) => row.extend(["-".into(), "-".into(), "unbounded".into()]),
        }
        let classic = bounds.classic.as_ref().ok().map(|r| r.response);
        row.push(verdict(classic, m.deadline).into());
        match &bounds.corrected {
            Ok(c) => row.extend([
                t(c.worst.blocking),
                t(c.worst.queuing),
                t(c.worst.response),
                format!("{}/{}", c.worst_instance, c.instances),
            ]),
            Err(_) => row.extend(["-", "-", "unbounded", "-"].map(String::from)),
        }
        let corrected = bounds.corrected.as_ref().ok().map(|c| c.worst.response);
        row.push(verdict(corrected, m.deadline).into());
        table.row(row);
    }
    let mut out = header(set, analysis);
    out.push('\n');
    out.push_str(&table.render());
    out.push('\n');
    out.push_str(&findings(set, analysis));
    out
}

fn header(set: &MessageSet, analysis: &Analysis) -> String {
    let base = set.time_base;
    let title = set.title.as_deref().unwrap_or("message set");
    let mut out = format!(
        "{title} ({}), {} messages\n",
        set.source,
        set.messages.len()
    );
    match base {
        TimeBase::Bitrate(bitrate) => out.push_str(&format!(
            "{bitrate} bit/s, τbit = {} ms; times in ms; C = worst-case stuffed frame + 3-bit intermission\n",
            base.format(base.bit_ticks())
        )),
        TimeBase::Abstract => {
            out.push_str("abstract time units, τbit = 1; C as given\n");
        }
    }
    out.push_str(&format!(
        "bus utilisation {:.1} %\n",
        analysis.utilisation * 100.0
    ));
    out
}

/// Deadline verdicts of both analyses, divergences, and the messages whose worst instance is
/// not the first.
fn findings(set: &MessageSet, analysis: &Analysis) -> String {
    let base = set.time_base;
    let mut out = String::new();
    let misses = |response: &dyn Fn(usize) -> Option<Ticks>| -> Vec<&str> {
        set.messages
            .iter()
            .enumerate()
            .filter(|(i, m)| response(*i).is_none_or(|r| r > m.deadline))
            .map(|(_, m)| m.name.as_str())
            .collect()
    };
    let classic = |i: usize| {
        analysis.messages[i]
            .classic
            .as_ref()
            .ok()
            .map(|r| r.response)
    };
    let corrected = |i: usize| {
        let c = analysis.messages[i].corrected.as_ref().ok();
        c.map(|c| c.worst.response)
    };
    for (name, missing) in [
        ("classic", misses(&classic)),
        ("corrected", misses(&corrected)),
    ] {
        if missing.is_empty() {
            out.push_str(&format!("{name}: every message meets its deadline\n"));
        } else {
            out.push_str(&format!(
                "{name}: {} of {} messages miss their deadline or have no bound: {}\n",
                missing.len(),
                set.messages.len(),
                missing.join(", ")
            ));
        }
    }
    for (m, bounds) in set.messages.iter().zip(&analysis.messages) {
        if let Err(Divergence { utilisation }) = bounds.corrected {
            out.push_str(&format!(
                "{}: no bound: the messages of its priority and above load the bus to {:.1} % (≥ 100 %), so its busy period never ends\n",
                m.name,
                utilisation * 100.0
            ));
        }
        if let Ok(c) = &bounds.corrected {
            if c.worst.response > c.first_response {
                out.push_str(&format!(
                    "{}: instance {} of its {}-instance busy period responds in {}{u}, the first in {}{u}: analysing only the first instance is optimistic here\n",
                    m.name,
                    c.worst_instance,
                    c.instances,
                    base.format(c.worst.response),
                    base.format(c.first_response),
                    u = unit_suffix(base),
                ));
            }
        }
    }
    out
}

fn unit_suffix(base: TimeBase) -> String {
    match base.unit() {
        "" => String::new(),
        unit => format!(" {unit}"),
    }
}

/// How an observed response compares with the two bounds.
pub fn observed_verdict(
    observed: &Observation,
    classic: Option<Ticks>,
    corrected: Option<Ticks>,
) -> &'static str {
    match (classic, corrected) {
        (_, None) => "no corrected bound",
        (_, Some(c)) if observed.exceeds(c) => "EXCEEDS CORRECTED BOUND",
        (Some(c), _) if observed.exceeds(c) => "exceeds classic bound",
        _ => "within both",
    }
}

/// The simulation table: per message the frame sent, both bounds and the observed worst case.
pub fn format_simulation(set: &MessageSet, analysis: &Analysis, sim: &Simulation) -> String {
    let base = set.time_base;
    let t = |ticks: Ticks| base.format(ticks);
    let mut table = Table::default();
    table.group(0, "");
    for (header, align) in [
        ("message", Align::Left),
        ("frame", Align::Left),
        ("bits", Align::Right),
        ("sent", Align::Right),
        ("classic R", Align::Right),
        ("corrected R", Align::Right),
        ("observed R", Align::Right),
        ("instance", Align::Right),
        ("scenario", Align::Left),
        ("", Align::Left),
    ] {
        table.column(header, align);
    }
    for (i, (m, bounds)) in set.messages.iter().zip(&analysis.messages).enumerate() {
        let classic = bounds.classic.as_ref().ok().map(|r| r.response);
        let corrected = bounds.corrected.as_ref().ok().map(|c| c.worst.response);
        let frame = &sim.frames[i];
        let mut row = vec![
            m.name.clone(),
            frame.to_string(),
            (m.transmission / base.bit_ticks()).to_string(),
            sent_bits(frame).to_string(),
            classic.map_or("unbounded".into(), t),
            corrected.map_or("unbounded".into(), t),
        ];
        match sim.observed[i] {
            Some(o) => row.extend([
                t(o.response_ticks()),
                o.instance.to_string(),
                set.messages[o.scenario].name.clone(),
                observed_verdict(&o, classic, corrected).into(),
            ]),
            None => row
                .extend(["-", "-", "-", "not simulated (no finite busy period)"].map(String::from)),
        }
        table.row(row);
    }
    let mut out = String::from(
        "\nsimulation: one RTL CAN core per message, each message's critical instant in turn\n\
         (bits = bound incl. intermission, sent = the frame's wire bits SOF..EOF + intermission;\n\
         observed R = initiating event to transmit-complete at the last EOF bit)\n\n",
    );
    out.push_str(&table.render());
    out.push_str(&format!(
        "\ncritical instants simulated: {} of {}; {} frames, {} ms of bus time\n",
        set.messages.len() - sim.skipped.len(),
        set.messages.len(),
        sim.frames_sent,
        sim.simulated_fs / crate::engine::time::FS_PER_MS
    ));
    out
}

/// Wire bits of `frame` plus the intermission, comparable with the bound C in bits.
pub fn sent_bits(frame: &golden::frame::Frame) -> u64 {
    encode(frame).len() as u64 + u64::from(golden::frame::INTERMISSION_BITS)
}

/// The CSV report: one header line and one line per message; times in the file's unit; the
/// observed columns only with a simulation.
pub fn format_csv(set: &MessageSet, analysis: &Analysis, sim: Option<&Simulation>) -> String {
    let base = set.time_base;
    let unit = match base.unit() {
        "" => String::new(),
        unit => format!("_{unit}"),
    };
    let times = [
        "transmission",
        "period",
        "jitter",
        "deadline",
        "classic_blocking",
        "classic_queuing",
        "classic_response",
    ];
    let mut headers: Vec<String> = ["message", "id", "extended", "node", "dlc", "frame_bits"]
        .map(String::from)
        .into();
    headers.extend(times.iter().map(|h| format!("{h}{unit}")));
    headers.push("classic_schedulable".into());
    for h in [
        "corrected_blocking",
        "corrected_queuing",
        "corrected_response",
        "corrected_busy_period",
    ] {
        headers.push(format!("{h}{unit}"));
    }
    headers.extend(
        [
            "corrected_instances",
            "corrected_worst_instance",
            "corrected_schedulable",
        ]
        .map(String::from),
    );
    if sim.is_some() {
        headers.push("sent_bits".into());
        headers.push(format!("observed_response{unit}"));
        headers.extend(["observed_instance", "observed_scenario"].map(String::from));
    }
    let mut out = csv_line(&headers);
    let t = |ticks: Ticks| base.format(ticks);
    for (i, (m, bounds)) in set.messages.iter().zip(&analysis.messages).enumerate() {
        let mut row = message_cells(m, base);
        let classic = bounds.classic.as_ref().ok();
        row.extend(response_cells(classic, t));
        row.push(verdict(classic.map(|r| r.response), m.deadline).into());
        let corrected = bounds.corrected.as_ref().ok();
        row.extend(response_cells(corrected.map(|c| &c.worst), t));
        row.extend(corrected_cells(corrected, t));
        row.push(verdict(corrected.map(|c| c.worst.response), m.deadline).into());
        if let Some(sim) = sim {
            row.push(sent_bits(&sim.frames[i]).to_string());
            match sim.observed[i] {
                Some(o) => row.extend([
                    t(o.response_ticks()),
                    o.instance.to_string(),
                    set.messages[o.scenario].name.clone(),
                ]),
                None => row.extend([String::new(), String::new(), String::new()]),
            }
        }
        out.push_str(&csv_line(&row));
    }
    out
}

fn message_cells(m: &Message, base: TimeBase) -> Vec<String> {
    let bits = match base {
        TimeBase::Bitrate(_) => (m.transmission / base.bit_ticks()).to_string(),
        TimeBase::Abstract => String::new(),
    };
    let mut cells = vec![
        m.name.clone(),
        format!("0x{}", m.id),
        m.id.is_extended().to_string(),
        m.node.clone().unwrap_or_default(),
        m.dlc.map(|d| d.to_string()).unwrap_or_default(),
        bits,
    ];
    cells.extend([m.transmission, m.period, m.jitter, m.deadline].map(|x| base.format(x)));
    cells
}

fn response_cells(r: Option<&Response>, t: impl Fn(Ticks) -> String) -> Vec<String> {
    match r {
        Some(r) => vec![t(r.blocking), t(r.queuing), t(r.response)],
        None => vec![String::new(); 3],
    }
}

fn corrected_cells(c: Option<&Corrected>, t: impl Fn(Ticks) -> String) -> Vec<String> {
    match c {
        Some(c) => vec![
            t(c.busy_period),
            c.instances.to_string(),
            c.worst_instance.to_string(),
        ],
        None => vec![String::new(); 3],
    }
}

/// One CSV line; fields with a comma, quote or line break are quoted (RFC 4180).
fn csv_line(fields: &[String]) -> String {
    let quoted: Vec<String> = fields
        .iter()
        .map(|f| {
            if f.contains([',', '"', '\n', '\r']) {
                format!("\"{}\"", f.replace('"', "\"\""))
            } else {
                f.clone()
            }
        })
        .collect();
    quoted.join(",") + "\n"
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Align {
    Left,
    Right,
}

/// A plain-text table: padded columns, optional group labels above runs of columns.
#[derive(Default)]
struct Table {
    headers: Vec<(String, Align)>,
    /// (first column, label) of each group; a group runs to the next one.
    groups: Vec<(usize, String)>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn column(&mut self, header: &str, align: Align) {
        self.headers.push((header.to_string(), align));
    }

    fn group(&mut self, first: usize, label: &str) {
        self.groups.push((first, label.to_string()));
    }

    fn width(&self) -> usize {
        self.headers.len()
    }

    fn has(&self, header: &str) -> bool {
        self.headers.iter().any(|(h, _)| h == header)
    }

    fn row(&mut self, row: Vec<String>) {
        debug_assert_eq!(row.len(), self.headers.len());
        self.rows.push(row);
    }

    fn render(&self) -> String {
        let widths: Vec<usize> = (0..self.width())
            .map(|c| {
                let cells = self.rows.iter().map(|r| r[c].chars().count());
                cells
                    .chain([self.headers[c].0.chars().count()])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let line = |cells: &[String]| -> String {
            let padded: Vec<String> = cells
                .iter()
                .zip(&widths)
                .zip(&self.headers)
                .map(|((cell, &w), (_, align))| match align {
                    Align::Left => format!("{cell:<w$}"),
                    Align::Right => format!("{cell:>w$}"),
                })
                .collect();
            padded.join("  ").trim_end().to_string() + "\n"
        };
        let mut out = String::new();
        if self.groups.iter().any(|(_, label)| !label.is_empty()) {
            out.push_str(&self.group_line(&widths));
        }
        let headers: Vec<String> = self.headers.iter().map(|(h, _)| h.clone()).collect();
        out.push_str(&line(&headers));
        for row in &self.rows {
            out.push_str(&line(row));
        }
        out
    }

    /// The group labels, each centred in dashes over its columns.
    fn group_line(&self, widths: &[usize]) -> String {
        let start = |column: usize| widths[..column].iter().map(|w| w + 2).sum::<usize>();
        let mut out = String::new();
        for (g, (first, label)) in self.groups.iter().enumerate() {
            let end = self
                .groups
                .get(g + 1)
                .map_or(self.width(), |(next, _)| *next);
            if label.is_empty() || end == *first {
                continue;
            }
            let span = start(end) - 2 - start(*first);
            out.push_str(&" ".repeat(start(*first).saturating_sub(out.chars().count())));
            let dashes = span.saturating_sub(label.chars().count() + 2);
            let left = dashes / 2;
            out.push_str(&format!(
                "{} {label} {}",
                "-".repeat(left),
                "-".repeat(dashes - left)
            ));
        }
        out.trim_end().to_string() + "\n"
    }
}
