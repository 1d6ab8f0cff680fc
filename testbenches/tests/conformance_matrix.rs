//! Keeps docs/CONFORMANCE.md honest: every test it names exists in `testbenches/tests`, every test named
//! after a catalog ID (`fr_01_…`, `fr_07_fe_03_…`) is listed in that ID's row, every row marked pass or
//! partial names at least one test, and each row's "runs on" column says where its tests run (bit
//! timing logic, core, complete controller through its registers).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Catalog IDs a test name starts with: `ec_01_03_04_x` → EC-01, EC-03, EC-04; `if_03_bt_13_x` →
/// IF-03, BT-13.
fn ids_of(test: &str) -> Vec<String> {
    let parts: Vec<&str> = test.split('_').collect();
    let is_group = |p: &str| p.len() == 2 && p.chars().all(|c| c.is_ascii_lowercase());
    let is_number = |p: &str| p.len() == 2 && p.chars().all(|c| c.is_ascii_digit());
    let (mut ids, mut group, mut i) = (Vec::new(), None, 0);
    while i < parts.len() {
        if is_group(parts[i]) && parts.get(i + 1).is_some_and(|p| is_number(p)) {
            group = Some(parts[i].to_uppercase());
            ids.push(format!("{}-{}", parts[i].to_uppercase(), parts[i + 1]));
            i += 2;
        } else if let (Some(g), true) = (&group, is_number(parts[i])) {
            ids.push(format!("{g}-{}", parts[i]));
            i += 1;
        } else {
            break;
        }
    }
    ids
}

/// Where a catalog test runs: on the bit timing logic alone, on the bare RTL core, on the complete
/// controller through its registers. The matrix names them in this order, joined by " + ".
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum RunsOn {
    BitTiming,
    Core,
    Registers,
}

impl RunsOn {
    fn name(self) -> &'static str {
        match self {
            RunsOn::BitTiming => "bit timing",
            RunsOn::Core => "core",
            RunsOn::Registers => "registers",
        }
    }
}

/// Where the `#[test]` functions of a test file run: on the complete controller if the file uses the
/// controller bench, on the bit timing logic if it uses the bit-timing bench, on the core otherwise.
fn runs_of_plain_tests(text: &str) -> RunsOn {
    if text.contains("ControllerBench") {
        RunsOn::Registers
    } else if text.contains("BtBench") {
        RunsOn::BitTiming
    } else {
        RunsOn::Core
    }
}

/// The identifiers listed in the `on_both_iuts!` invocations of a test file (attributes before a
/// name, `#[ignore = "…"]`, are skipped).
fn listed_for_both_iuts(text: &str) -> Vec<String> {
    let mut names = Vec::new();
    for invocation in text.split("\ntestbenches::on_both_iuts! {").skip(1) {
        let mut rest = invocation;
        loop {
            rest = rest.trim_start_matches(|c: char| c.is_whitespace() || c == ',');
            if let Some(attribute) = rest.strip_prefix("#[") {
                rest = &attribute[attribute.find(']').expect("attribute closed") + 1..];
                continue;
            }
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if name.is_empty() {
                break;
            }
            rest = &rest[name.len()..];
            names.push(name);
        }
    }
    names
}

/// Every test named after a catalog ID in the integration tests, with where it runs: `#[test]`
/// functions, and the scenarios of `on_both_iuts!` (core and registers).
fn catalog_tests() -> BTreeMap<String, BTreeSet<RunsOn>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut tests: BTreeMap<String, BTreeSet<RunsOn>> = BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let text = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        let plain = runs_of_plain_tests(&text);
        for after_attribute in text.split("#[test]").skip(1) {
            let Some(start) = after_attribute.find("fn ") else {
                continue;
            };
            let name: String = after_attribute[start + 3..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            tests.entry(name).or_default().insert(plain);
        }
        for name in listed_for_both_iuts(&text) {
            tests
                .entry(name)
                .or_default()
                .extend([RunsOn::Core, RunsOn::Registers]);
        }
    }
    tests.retain(|name, _| !ids_of(name).is_empty());
    tests
}

/// One matrix row: the tests it names, where they run, its status text.
struct Row {
    tests: Vec<String>,
    runs_on: String,
    status: String,
}

/// The matrix rows by ID.
fn matrix() -> BTreeMap<String, Row> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/CONFORMANCE.md");
    let text = std::fs::read_to_string(path).unwrap();
    let mut rows = BTreeMap::new();
    for line in text
        .lines()
        .filter(|l| l.starts_with("| ") && l.as_bytes()[4] == b'-')
    {
        let cells: Vec<&str> = line.split(" | ").collect();
        assert_eq!(cells.len(), 4, "ID | test | runs on | status: {line}");
        let id = cells[0].trim_start_matches("| ")[..5].to_string();
        let tests = cells[1]
            .split(", ")
            .filter(|t| t.starts_with('`'))
            .map(|t| t.trim_matches('`').to_string())
            .collect();
        let runs_on = cells[2].to_string();
        let status = cells[3].trim_end_matches(" |").to_string();
        rows.insert(
            id,
            Row {
                tests,
                runs_on,
                status,
            },
        );
    }
    rows
}

#[test]
fn every_listed_test_exists_and_every_catalog_test_is_listed() {
    let tests = catalog_tests();
    let rows = matrix();
    assert!(
        rows.len() >= 100,
        "the matrix lists the whole catalog ({} rows)",
        rows.len()
    );
    for (id, row) in &rows {
        let mut runs_on: BTreeSet<RunsOn> = BTreeSet::new();
        for t in &row.tests {
            let runs = tests
                .get(t)
                .unwrap_or_else(|| panic!("{id}: `{t}` is listed but no such test exists"));
            runs_on.extend(runs);
        }
        let passing = row.status.starts_with("pass") || row.status.starts_with("partial");
        assert!(
            !passing || !row.tests.is_empty(),
            "{id} is marked {:?} without a test",
            row.status
        );
        assert!(
            passing || row.tests.is_empty(),
            "{id} has tests but is marked {:?}",
            row.status
        );
        let names: Vec<&str> = runs_on.iter().map(|r| r.name()).collect();
        let expected = if names.is_empty() {
            "–".to_string()
        } else {
            names.join(" + ")
        };
        assert_eq!(row.runs_on, expected, "{id}: where its tests run");
    }
    for t in tests.keys() {
        for id in ids_of(t) {
            let row = rows
                .get(&id)
                .unwrap_or_else(|| panic!("`{t}` names {id}, not in the matrix"));
            assert!(
                row.tests.contains(t),
                "`{t}` is not listed in the row of {id}"
            );
        }
    }
}

#[test]
fn test_names_map_to_catalog_ids() {
    assert_eq!(
        ids_of("ec_01_03_04_09_receiver"),
        ["EC-01", "EC-03", "EC-04", "EC-09"]
    );
    assert_eq!(ids_of("if_03_bt_13_pending"), ["IF-03", "BT-13"]);
    assert!(ids_of("every_listed_test_exists").is_empty());
}

#[test]
fn scenario_lists_are_read_with_their_attributes() {
    let text = "fn x() {}\ntestbenches::on_both_iuts! {\n    fr_01_a,\n    #[ignore = \"long: a, b\"]\n    \
                fr_02_b,\n}\nfn fr_03_c() {}\n";
    assert_eq!(listed_for_both_iuts(text), ["fr_01_a", "fr_02_b"]);
}
