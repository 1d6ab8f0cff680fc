//! GTKWave views of a scenario's VCD. A run with a VCD also writes, beside it:
//!
//! * `NAME.gtkw`, the view: the bus and the number of the frame on it (`top.frame`, shown as the
//!   frame itself), then one group per node: `tx`, `rx`, sample point, bit timing segment (by
//!   name), protocol state (by name), TEC, REC and `irq_n`;
//! * `NAME.frames.filter`, the GTKWave translate filter that shows each frame number as the bus
//!   log's line(s) for that frame (`5: ERROR FRAME in ACK delimiter of 200#DEADBEEF ...`);
//! * `state.filter` and `segment.filter`, the names of the protocol states and segments (the same
//!   files as in `waves/`).
//!
//! The view names the filters by paths in the same form as the VCD's (relative stays relative):
//! open it from the directory the run was started in, as the printed `gtkwave` command does.

use std::path::{Path, PathBuf};

use crate::decode::bus_decoder::INTERFACE;
use crate::engine::time::FS_PER_NS;
use crate::engine::trace::Probe;

use super::output::write_file;
use super::report::RunReport;
use super::{Scenario, ScenarioError};

/// The names of the protocol states (`ProtocolState` values), as a GTKWave translate filter.
pub const STATE_FILTER: &str = include_str!("../../../waves/state.filter");
/// The names of the bit timing segments, as a GTKWave translate filter.
pub const SEGMENT_FILTER: &str = include_str!("../../../waves/segment.filter");
/// The frame number traced beside the bus: 1 from the first start of frame on (0 before it); it
/// wraps after 65535.
pub const FRAME_PROBE: Probe = Probe {
    name: "frame",
    width: 16,
};
/// Hex digits GTKWave shows for [`FRAME_PROBE`].
const FRAME_DIGITS: usize = 4;
/// Where the view starts before its marker, in ns.
const LEAD_IN_NS: u64 = 40_000;

/// The files of a view, beside a VCD.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ViewFiles {
    /// The GTKWave save file.
    pub gtkw: PathBuf,
    /// Frame numbers to bus log lines.
    pub frames_filter: PathBuf,
    /// Protocol state names.
    pub state_filter: PathBuf,
    /// Segment names.
    pub segment_filter: PathBuf,
}

impl ViewFiles {
    /// The view files of the VCD `vcd` (`waves/demo.vcd`: `waves/demo.gtkw`,
    /// `waves/demo.frames.filter`, `waves/state.filter`, `waves/segment.filter`).
    pub fn beside(vcd: &Path) -> ViewFiles {
        let dir = vcd.parent().unwrap_or(Path::new(""));
        let stem = vcd
            .file_stem()
            .map_or("trace".into(), |s| s.to_string_lossy().into_owned());
        ViewFiles {
            gtkw: dir.join(format!("{stem}.gtkw")),
            frames_filter: dir.join(format!("{stem}.frames.filter")),
            state_filter: dir.join("state.filter"),
            segment_filter: dir.join("segment.filter"),
        }
    }
}

/// Writes the view of `report`'s VCD at `vcd`; returns the save file's path.
pub fn write_view(
    scenario: &Scenario,
    report: &RunReport,
    vcd: &Path,
) -> Result<PathBuf, ScenarioError> {
    let files = ViewFiles::beside(vcd);
    write_file(&files.frames_filter, &frames_filter_text(report))?;
    write_file(&files.state_filter, STATE_FILTER)?;
    write_file(&files.segment_filter, SEGMENT_FILTER)?;
    write_file(&files.gtkw, &view_text(scenario, report, vcd))
}

/// The translate filter from frame numbers to what the bus log says about each frame: every event
/// from its start of frame to the next one.
pub fn frames_filter_text(report: &RunReport) -> String {
    let mut out = format!(
        "# frame number -> bus log (written by cansim)\n{:0FRAME_DIGITS$X} -\n",
        0
    );
    let starts = &report.frame_starts;
    let prefix = format!(") {INTERFACE} ");
    for (k, &start) in starts.iter().enumerate() {
        let end = starts.get(k + 1).copied().unwrap_or(u64::MAX);
        let lines: Vec<String> = report
            .log
            .iter()
            .filter(|e| (start..end).contains(&e.start_fs))
            .map(|e| {
                let line = e.to_string();
                line.split_once(&prefix)
                    .map_or(line.clone(), |(_, rest)| rest.to_string())
            })
            .collect();
        let number = (k + 1) & ((1 << FRAME_PROBE.width) - 1);
        out += &format!(
            "{number:0FRAME_DIGITS$X} {}: {}\n",
            k + 1,
            lines.join(" / ")
        );
    }
    out
}

/// The GTKWave save file for `report`'s VCD at `vcd`; its marker is at the first fault, if any.
pub fn view_text(scenario: &Scenario, report: &RunReport, vcd: &Path) -> String {
    let files = ViewFiles::beside(vcd);
    let marker_ns = report.faults.first().map(|f| f.start_fs / FS_PER_NS);
    let mut out = format!(
        "[*] GTKWave view of {}: the bus and the frame on it (as the bus log\n\
         [*] tells it), then per node its pins, bit timing, protocol state, error counters and\n\
         [*] interrupt line. Written by cansim; open with: gtkwave {} {}\n",
        scenario.path.display(),
        vcd.display(),
        files.gtkw.display()
    );
    out += &format!(
        "[timestart] {}\n[size] 1600 900\n[pos] -1 -1\n*-15.000000 {}\n",
        marker_ns.map_or(0, |m| m.saturating_sub(LEAD_IN_NS)),
        marker_ns.map_or(-1, |m| m as i64)
    );
    out += "[treeopen] top.\n[sst_width] 200\n[signals_width] 260\n[sst_expanded] 1\n\
            [sst_vpaned_height] 250\n@28\ntop.bus\n";
    out += &filtered_vector(3, &files.frames_filter, "top", FRAME_PROBE);
    for node in &scenario.nodes {
        let n = &node.name;
        out += &format!("@800200\n-{n}\n@28\n{n}.tx\n@28\n{n}.rx\n@28\n{n}.sample_point\n");
        out += &filtered_vector(
            1,
            &files.segment_filter,
            n,
            Probe {
                name: "segment",
                width: 2,
            },
        );
        out += &filtered_vector(
            2,
            &files.state_filter,
            n,
            Probe {
                name: "state",
                width: 5,
            },
        );
        for counter in ["tec", "rec"] {
            out += &format!(
                "@24\n{}\n",
                vector(
                    n,
                    Probe {
                        name: counter,
                        width: 8
                    }
                )
            );
        }
        out += &format!("@28\n{n}.irq_n\n@1000200\n-{n}\n");
    }
    out
}

/// A vector shown through translate filter number `number` read from `filter`.
fn filtered_vector(number: u32, filter: &Path, scope: &str, probe: Probe) -> String {
    format!(
        "^{number} {}\n@2022\n{}\n",
        filter.display(),
        vector(scope, probe)
    )
}

/// `#{a.state} a.state[4] a.state[3] ... a.state[0]`: the bit-select wires of a probe as one
/// vector.
fn vector(scope: &str, probe: Probe) -> String {
    let bits: Vec<String> = (0..probe.width)
        .rev()
        .map(|i| format!("{scope}.{}[{i}]", probe.name))
        .collect();
    format!("#{{{scope}.{}}} {}", probe.name, bits.join(" "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_files_sit_beside_the_vcd() {
        let files = ViewFiles::beside(Path::new("out/run.vcd"));
        assert_eq!(files.gtkw, Path::new("out/run.gtkw"));
        assert_eq!(files.frames_filter, Path::new("out/run.frames.filter"));
        assert_eq!(files.state_filter, Path::new("out/state.filter"));
        assert_eq!(files.segment_filter, Path::new("out/segment.filter"));
    }

    #[test]
    fn the_state_filter_names_every_protocol_state_at_its_traced_value() {
        let mut lines = 0;
        for line in STATE_FILTER.lines() {
            let (value, name) = line.split_once(' ').expect("`XX Name` lines");
            let value = u64::from_str_radix(value, 16).expect("a hex value");
            let state = crate::nodes::controller_node::protocol_state(value);
            assert_eq!(state as u64, value, "the traced value of {state:?}");
            assert_eq!(format!("{state:?}"), name, "state.filter line {line:?}");
            lines += 1;
        }
        assert_eq!(lines, 16, "one line per protocol state");
    }

    #[test]
    fn a_vector_lists_its_bits_from_the_top() {
        let probe = Probe {
            name: "segment",
            width: 2,
        };
        assert_eq!(vector("b", probe), "#{b.segment} b.segment[1] b.segment[0]");
    }
}
