//! Keeps docs/CONFORMANCE.md honest: every test it names exists in `testbenches/tests`, every test named
//! after a catalog ID (`fr_01_…`, `fr_07_fe_03_…`) is listed in that ID's row, and every row marked
//! pass or partial names at least one test.

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

/// Every `#[test]` function in the integration tests whose name starts with a catalog ID.
fn catalog_tests() -> BTreeSet<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut names = BTreeSet::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let text = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        for after_attribute in text.split("#[test]").skip(1) {
            let Some(start) = after_attribute.find("fn ") else {
                continue;
            };
            let name: String = after_attribute[start + 3..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !ids_of(&name).is_empty() {
                names.insert(name);
            }
        }
    }
    names
}

/// The matrix rows: ID → (tests named in the row, status text).
fn matrix() -> BTreeMap<String, (Vec<String>, String)> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/CONFORMANCE.md");
    let text = std::fs::read_to_string(path).unwrap();
    let mut rows = BTreeMap::new();
    for line in text
        .lines()
        .filter(|l| l.starts_with("| ") && l.as_bytes()[4] == b'-')
    {
        let cells: Vec<&str> = line.split(" | ").collect();
        let id = cells[0].trim_start_matches("| ")[..5].to_string();
        let tests = cells[1]
            .split(", ")
            .filter(|t| t.starts_with('`'))
            .map(|t| t.trim_matches('`').to_string())
            .collect();
        let status = cells.last().unwrap().trim_end_matches(" |").to_string();
        rows.insert(id, (tests, status));
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
    for (id, (listed, status)) in &rows {
        for t in listed {
            assert!(
                tests.contains(t),
                "{id}: `{t}` is listed but no such test exists"
            );
        }
        let passing = status.starts_with("pass") || status.starts_with("partial");
        assert!(
            !passing || !listed.is_empty(),
            "{id} is marked {status:?} without a test"
        );
        assert!(
            passing || listed.is_empty(),
            "{id} has tests but is marked {status:?}"
        );
    }
    for t in &tests {
        for id in ids_of(t) {
            let row = rows
                .get(&id)
                .unwrap_or_else(|| panic!("`{t}` names {id}, not in the matrix"));
            assert!(row.0.contains(t), "`{t}` is not listed in the row of {id}");
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
