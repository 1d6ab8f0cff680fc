//! Campaigns over several machines: `cansim campaign --shard K/N --out FILE.jsonl` runs the cases
//! i with i mod N = K − 1 (case i is drawn from the seed and i alone, so it is the same case whatever
//! N) and writes the slice's counts and failures as JSON lines; `cansim campaign-merge FILE…` adds
//! slices up into the report of one full run, and refuses slices of different campaigns, the same
//! shard twice, a missing shard or a file cut short.
//!
//! A slice file: one JSON object per line, tagged by `record`: first `slice` (seed, faults, shard,
//! shards, cases run), then one `outcome` per outcome class met (its count), then one `failure` per
//! case that broke a rule (its index and the violations).

use std::collections::BTreeSet;
use std::io::{self, BufRead, BufWriter, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::workloads::campaign::{Outcome, Summary};

/// The part of a campaign a run takes: shard `index` (1-based) of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, 1..=count.
    pub index: u64,
    /// Shards in all.
    pub count: u64,
}

impl Shard {
    /// The whole campaign.
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Parses `K/N` (1 ≤ K ≤ N).
    pub fn parse(text: &str) -> Result<Shard, String> {
        let wrong = || format!("--shard {text}: expected K/N with 1 <= K <= N, e.g. 2/8");
        let (k, n) = text.split_once('/').ok_or_else(wrong)?;
        let index: u64 = k.trim().parse().map_err(|_| wrong())?;
        let count: u64 = n.trim().parse().map_err(|_| wrong())?;
        if index == 0 || index > count {
            return Err(wrong());
        }
        Ok(Shard { index, count })
    }

    /// The case number of this shard's `n`-th case (0-based).
    pub fn case(&self, n: u64) -> u64 {
        (self.index - 1).saturating_add(n.saturating_mul(self.count))
    }

    /// Cases of `0..faults` in this shard.
    pub fn len(&self, faults: u64) -> u64 {
        (faults + self.count - self.index) / self.count
    }

    /// Whether case `case` falls to this shard.
    pub fn holds(&self, case: u64) -> bool {
        case % self.count == self.index - 1
    }
}

/// One line of a slice file.
#[derive(Serialize, Deserialize)]
#[serde(tag = "record", rename_all = "snake_case")]
enum Record {
    Slice {
        seed: u64,
        faults: u64,
        shard: u64,
        shards: u64,
        cases: u64,
    },
    Outcome {
        outcome: Outcome,
        count: usize,
    },
    Failure {
        case: u64,
        violations: Vec<String>,
    },
}

/// A slice of a campaign: which cases it ran and what came out.
#[derive(Clone, Debug, PartialEq)]
pub struct Slice {
    /// Seed of the campaign.
    pub seed: u64,
    /// Cases of the whole campaign.
    pub faults: u64,
    /// The cases this slice ran.
    pub shard: Shard,
    /// Its counts and failures.
    pub summary: Summary,
}

/// Writes `slice` to `path` as JSON lines.
pub fn write_slice(path: &Path, slice: &Slice) -> io::Result<()> {
    let mut out = BufWriter::new(std::fs::File::create(path)?);
    let mut line = |record: &Record| -> io::Result<()> {
        serde_json::to_writer(&mut out, record)?;
        out.write_all(b"\n")
    };
    line(&Record::Slice {
        seed: slice.seed,
        faults: slice.faults,
        shard: slice.shard.index,
        shards: slice.shard.count,
        cases: slice.summary.cases as u64,
    })?;
    for (&outcome, &count) in &slice.summary.outcomes {
        line(&Record::Outcome { outcome, count })?;
    }
    for (case, violations) in &slice.summary.failures {
        line(&Record::Failure {
            case: *case,
            violations: violations.clone(),
        })?;
    }
    out.flush()
}

/// Reads a slice file; errors name the file and line.
pub fn read_slice(path: &Path) -> Result<Slice, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut slice: Option<Slice> = None;
    for (number, text) in io::BufReader::new(file).lines().enumerate() {
        let at = format!("{}:{}", path.display(), number + 1);
        let text = text.map_err(|e| format!("{at}: {e}"))?;
        if text.trim().is_empty() {
            continue;
        }
        let record: Record = serde_json::from_str(&text).map_err(|e| format!("{at}: {e}"))?;
        match (record, slice.as_mut()) {
            (
                Record::Slice {
                    seed,
                    faults,
                    shard,
                    shards,
                    cases,
                },
                None,
            ) => {
                let shard =
                    Shard::parse(&format!("{shard}/{shards}")).map_err(|e| format!("{at}: {e}"))?;
                if cases != shard.len(faults) {
                    return Err(format!(
                        "{at}: shard {}/{} of {faults} cases has {} cases, the slice says {cases}",
                        shard.index,
                        shard.count,
                        shard.len(faults)
                    ));
                }
                slice = Some(Slice {
                    seed,
                    faults,
                    shard,
                    summary: Summary {
                        cases: cases as usize,
                        ..Summary::default()
                    },
                });
            }
            (Record::Slice { .. }, Some(_)) => return Err(format!("{at}: a second `slice` line")),
            (_, None) => return Err(format!("{at}: the first line must be the `slice` record")),
            (Record::Outcome { outcome, count }, Some(slice)) => {
                *slice.summary.outcomes.entry(outcome).or_default() += count;
            }
            (Record::Failure { case, violations }, Some(slice)) => {
                if case >= slice.faults || !slice.shard.holds(case) {
                    return Err(format!(
                        "{at}: case {case} is not in shard {}/{}",
                        slice.shard.index, slice.shard.count
                    ));
                }
                slice.summary.failures.push((case, violations));
            }
        }
    }
    let slice = slice.ok_or_else(|| format!("{}: empty slice file", path.display()))?;
    let counted: usize = slice.summary.outcomes.values().sum();
    if counted != slice.summary.cases {
        return Err(format!(
            "{}: the outcomes count {counted} cases, the slice ran {} (file cut short?)",
            path.display(),
            slice.summary.cases
        ));
    }
    Ok(slice)
}

/// Adds slices up into the report of one run of the whole campaign. Refuses slices of different
/// campaigns (seed, cases, shard count), the same shard twice and a missing shard.
pub fn merge(slices: &[Slice]) -> Result<Slice, String> {
    let first = slices.first().ok_or("no slice to merge")?;
    let shards = first.shard.count;
    let mut seen = BTreeSet::new();
    let mut summary = Summary::default();
    for slice in slices {
        if (slice.seed, slice.faults, slice.shard.count) != (first.seed, first.faults, shards) {
            return Err(format!(
                "slices of different campaigns: seed {} with {} cases in {} shards, and seed {} with {} cases in {} shards",
                first.seed, first.faults, shards, slice.seed, slice.faults, slice.shard.count
            ));
        }
        if !seen.insert(slice.shard.index) {
            return Err(format!(
                "shard {}/{shards} given twice (its cases would count twice)",
                slice.shard.index
            ));
        }
        summary.cases += slice.summary.cases;
        for (&outcome, &count) in &slice.summary.outcomes {
            *summary.outcomes.entry(outcome).or_default() += count;
        }
        summary
            .failures
            .extend(slice.summary.failures.iter().cloned());
    }
    let missing: Vec<String> = (1..=shards)
        .filter(|k| !seen.contains(k))
        .map(|k| format!("{k}/{shards}"))
        .collect();
    if !missing.is_empty() {
        return Err(format!("missing shards: {}", missing.join(", ")));
    }
    summary.failures.sort_by_key(|(case, _)| *case);
    Ok(Slice {
        seed: first.seed,
        faults: first.faults,
        shard: Shard::WHOLE,
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_partition_the_cases() {
        for count in 1..=5 {
            let mut all: Vec<u64> = (1..=count)
                .flat_map(|index| {
                    let shard = Shard { index, count };
                    (0..shard.len(23)).map(move |n| shard.case(n))
                })
                .collect();
            all.sort_unstable();
            assert_eq!(all, (0..23).collect::<Vec<_>>(), "{count} shards");
        }
    }

    #[test]
    fn bad_shards_are_refused() {
        for text in ["0/2", "3/2", "1", "a/b", "1/0"] {
            assert!(Shard::parse(text).is_err(), "{text}");
        }
        assert_eq!(Shard::parse("2/8"), Ok(Shard { index: 2, count: 8 }));
    }
}
