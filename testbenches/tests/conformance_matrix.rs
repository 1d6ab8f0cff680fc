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

/// The "runs on" cell of a matrix row for tests that run on `runs_on` ("–" for none).
fn runs_on_cell(runs_on: &BTreeSet<RunsOn>) -> String {
    let names: Vec<&str> = runs_on.iter().map(|r| r.name()).collect();
    if names.is_empty() {
        "–".to_string()
    } else {
        names.join(" + ")
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

/// The texts of the integration test files.
fn test_file_texts() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    std::fs::read_dir(dir)
        .unwrap()
        .map(|entry| std::fs::read_to_string(entry.unwrap().path()).unwrap())
        .collect()
}

/// The `#[test]` functions of a test file: each name with the attribute lines between `#[test]`
/// and its `fn`.
fn test_functions(text: &str) -> Vec<(String, &str)> {
    let mut functions = Vec::new();
    for after_attribute in text.split("#[test]").skip(1) {
        let Some(start) = after_attribute.find("fn ") else {
            continue;
        };
        let name: String = after_attribute[start + 3..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        functions.push((name, &after_attribute[..start]));
    }
    functions
}

/// Every test named after a catalog ID in the integration tests, with where it runs: `#[test]`
/// functions, and the scenarios of `on_both_iuts!` (core and registers).
fn catalog_tests() -> BTreeMap<String, BTreeSet<RunsOn>> {
    let mut tests: BTreeMap<String, BTreeSet<RunsOn>> = BTreeMap::new();
    for text in test_file_texts() {
        let plain = runs_of_plain_tests(&text);
        for (name, _) in test_functions(&text) {
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
        assert_eq!(
            row.runs_on,
            runs_on_cell(&runs_on),
            "{id}: where its tests run"
        );
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

/// The ISO 16845-1:2016 test cases that apply to classical CAN (7.1.6, 7.1.7, 7.8.x, 8.8.x and 9.6.x
/// concern CAN FD only); "7.2.2 a" and "b" are the error-passive and restricted-operation variants.
fn iso_clauses() -> Vec<String> {
    let mut clauses = Vec::new();
    let mut range = |prefix: &str, numbers: std::ops::RangeInclusive<u32>| {
        clauses.extend(numbers.map(|n| format!("{prefix}.{n}")));
    };
    range("7.1", 1..=5);
    range("7.1", 8..=12);
    range("7.2", 1..=11);
    range("7.3", 1..=4);
    range("7.4", 1..=7);
    range("7.5", 1..=7);
    range("7.6", 1..=22);
    range("7.7", 1..=8);
    range("7.7.9", 1..=2);
    range("7.7", 10..=11);
    range("8.1", 1..=8);
    range("8.2", 1..=8);
    range("8.3", 1..=4);
    range("8.4", 1..=5);
    range("8.5", 1..=15);
    range("8.6", 1..=21);
    range("8.7", 1..=9);
    for base in ISO_LETTERED {
        for letter in ["a", "b"] {
            clauses.push(format!("{base} {letter}"));
        }
    }
    clauses
}

/// The clauses with lettered variants.
const ISO_LETTERED: [&str; 3] = ["7.2.2", "7.2.3", "7.2.4"];

/// The ISO clause a test is named after: `iso_7_2_7_x` → 7.2.7, `iso_7_2_2_a_x` → 7.2.2 a,
/// `iso_7_7_9_1_x` → 7.7.9.1.
fn iso_clause_of(test: &str) -> Option<String> {
    let mut parts = test.strip_prefix("iso_")?.split('_').peekable();
    let mut numbers = Vec::new();
    while let Some(p) = parts.next_if(|p| !p.is_empty() && p.chars().all(|c| c.is_ascii_digit())) {
        numbers.push(p);
    }
    if numbers.len() < 3 {
        return None;
    }
    let clause = numbers.join(".");
    match parts.peek() {
        Some(&letter)
            if ISO_LETTERED.contains(&clause.as_str()) && ["a", "b"].contains(&letter) =>
        {
            Some(format!("{clause} {letter}"))
        }
        _ => Some(clause),
    }
}

/// An ISO test: where it runs, and whether it is ignored (a case that does not pass yet).
#[derive(Default)]
struct IsoTest {
    runs_on: BTreeSet<RunsOn>,
    ignored: bool,
}

/// The names in the `on_both_iuts!` lists of a test file with whether an `#[ignore …]` precedes them.
fn ignored_for_both_iuts(text: &str) -> Vec<(String, bool)> {
    let mut names = Vec::new();
    for invocation in text.split("\ntestbenches::on_both_iuts! {").skip(1) {
        let body = &invocation[..invocation.find("\n}").unwrap_or(invocation.len())];
        let mut ignored = false;
        for line in body.lines().map(str::trim) {
            if line.starts_with("#[ignore") {
                ignored = true;
            } else if let Some(name) = line.strip_suffix(',').or(Some(line)).filter(|n| {
                !n.is_empty() && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            }) {
                names.push((name.to_string(), ignored));
                ignored = false;
            }
        }
    }
    names
}

/// Every test named after an ISO clause, with where it runs and whether it is ignored.
fn iso_tests() -> BTreeMap<String, IsoTest> {
    let mut tests: BTreeMap<String, IsoTest> = BTreeMap::new();
    for text in test_file_texts() {
        let plain = runs_of_plain_tests(&text);
        for (name, attributes) in test_functions(&text) {
            let test = tests.entry(name).or_default();
            test.runs_on.insert(plain);
            test.ignored |= attributes.contains("#[ignore");
        }
        for (name, ignored) in ignored_for_both_iuts(&text) {
            let test = tests.entry(name).or_default();
            test.runs_on.extend([RunsOn::Core, RunsOn::Registers]);
            test.ignored |= ignored;
        }
    }
    tests.retain(|name, _| iso_clause_of(name).is_some());
    tests
}

/// One row of the ISO table: clause | tests | runs on | status | catalog IDs.
struct IsoRow {
    tests: Vec<String>,
    runs_on: String,
    status: String,
    catalog: Vec<String>,
}

/// The ISO table of docs/CONFORMANCE.md by clause, and its totals line.
fn iso_matrix() -> (BTreeMap<String, IsoRow>, String) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/CONFORMANCE.md");
    let text = std::fs::read_to_string(path).unwrap();
    let mut rows = BTreeMap::new();
    for line in text
        .lines()
        .filter(|l| l.starts_with("| ") && l.as_bytes()[2].is_ascii_digit())
    {
        let cells: Vec<&str> = line.trim_end_matches(" |").split(" | ").collect();
        assert_eq!(
            cells.len(),
            5,
            "clause | test | runs on | status | catalog: {line}"
        );
        let clause = cells[0].trim_start_matches("| ").to_string();
        let tests = cells[1]
            .split(", ")
            .filter(|t| t.starts_with('`'))
            .map(|t| t.trim_matches('`').to_string())
            .collect();
        let catalog = cells[4]
            .split(", ")
            .filter(|id| *id != "–")
            .map(str::to_string)
            .collect();
        let row = IsoRow {
            tests,
            runs_on: cells[2].to_string(),
            status: cells[3].to_string(),
            catalog,
        };
        assert!(
            rows.insert(clause.clone(), row).is_none(),
            "{clause} has two rows"
        );
    }
    let totals = text
        .lines()
        .find(|l| l.starts_with("ISO 16845-1 totals:"))
        .expect("an ISO totals line")
        .to_string();
    (rows, totals)
}

#[test]
fn every_iso_clause_has_a_row_and_every_iso_test_is_listed_in_it() {
    let tests = iso_tests();
    let (rows, totals) = iso_matrix();
    let catalog = matrix();
    let clauses = iso_clauses();
    assert_eq!(clauses.len(), 149, "the classical-CAN test cases");
    let listed: BTreeSet<&String> = rows.keys().collect();
    let expected: BTreeSet<&String> = clauses.iter().collect();
    assert_eq!(listed, expected, "one row per ISO clause");
    let mut counts = [0usize; 4];
    for (clause, row) in &rows {
        let mut runs_on: BTreeSet<RunsOn> = BTreeSet::new();
        let mut ignored = false;
        for t in &row.tests {
            let test = tests
                .get(t)
                .unwrap_or_else(|| panic!("{clause}: `{t}` is listed but no such test exists"));
            assert_eq!(
                iso_clause_of(t).as_deref(),
                Some(clause.as_str()),
                "`{t}` is named after another clause"
            );
            runs_on.extend(&test.runs_on);
            ignored |= test.ignored;
        }
        let kind = ["pass", "fails", "not applicable", "not yet"]
            .iter()
            .position(|k| row.status.starts_with(k))
            .unwrap_or_else(|| panic!("{clause}: unknown status {:?}", row.status));
        counts[kind] += 1;
        match kind {
            0 => assert!(
                !row.tests.is_empty() && !ignored,
                "{clause} is marked pass: it needs tests, none ignored"
            ),
            1 => assert!(
                ignored && row.status.len() > "fails: ".len(),
                "{clause} is marked as failing: its failing test is ignored and the row says why"
            ),
            _ => assert!(
                row.tests.is_empty() && (kind == 3 || row.status.len() > "not applicable: ".len()),
                "{clause} is {:?}: no test, and a reason if not applicable",
                row.status
            ),
        }
        assert_eq!(
            row.runs_on,
            runs_on_cell(&runs_on),
            "{clause}: where its tests run"
        );
        for id in &row.catalog {
            assert!(
                catalog.contains_key(id),
                "{clause}: unknown catalog ID {id}"
            );
        }
    }
    for t in tests.keys() {
        let clause = iso_clause_of(t).unwrap();
        let row = rows
            .get(&clause)
            .unwrap_or_else(|| panic!("`{t}` names {clause}, which has no row"));
        assert!(
            row.tests.contains(t),
            "`{t}` is not listed in the row of {clause}"
        );
    }
    let [pass, fail, not_applicable, not_yet] = counts;
    assert_eq!(
        totals,
        format!(
            "ISO 16845-1 totals: {} test cases: {pass} pass, {fail} fail, {not_applicable} not \
             applicable, {not_yet} not yet.",
            rows.len()
        )
    );
}

#[test]
fn iso_test_names_map_to_clauses() {
    assert_eq!(iso_clause_of("iso_7_2_7_x").as_deref(), Some("7.2.7"));
    assert_eq!(iso_clause_of("iso_7_2_2_a_x").as_deref(), Some("7.2.2 a"));
    assert_eq!(iso_clause_of("iso_7_1_9_a_frame").as_deref(), Some("7.1.9"));
    assert_eq!(iso_clause_of("iso_7_7_9_1_x").as_deref(), Some("7.7.9.1"));
    assert_eq!(iso_clause_of("fr_01_x"), None);
    let text = "testbenches::on_both_iuts! {\n    iso_7_1_1_a,\n    #[ignore = \"fails: x\"]\n    \
                iso_7_1_2_b,\n}\n";
    assert_eq!(
        ignored_for_both_iuts(&format!("\n{text}")),
        [
            ("iso_7_1_1_a".to_string(), false),
            ("iso_7_1_2_b".to_string(), true)
        ]
    );
}
