//! The formal proofs of the emitted Verilog (formal/*.sv, `make formal`, docs/FORMAL.md): every
//! property holds (for every depth where docs/FORMAL.md says so, otherwise for its stated bound), and
//! every deliberate break of a rule listed in a property file (a mutation of the Verilog) makes its
//! proof fail. The docs' table is checked against what the run printed.
//!
//! `cargo test` runs the proofs and checks that every mutation still applies to the Verilog (about a
//! minute); showing that each mutation is caught takes minutes more and is the ignored test, run by
//! `make formal`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Property name → the result line of scripts/formal.sh.
struct FormalRun {
    results: BTreeMap<String, String>,
    mutations: Vec<(String, String, String)>,
}

/// Runs scripts/formal.sh with `mutations` (`--mutations` proves them, `--mutation-texts` only
/// applies them).
fn run_formal(mutations: &str) -> FormalRun {
    let output = Command::new(workspace().join("scripts/formal.sh"))
        .arg(mutations)
        .current_dir(workspace())
        .output()
        .expect("scripts/formal.sh runs (yosys and yosys-abc: `make tools`)");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stdout}{stderr}");
    assert!(
        output.status.success() && stdout.contains("formal: all passed"),
        "make formal failed:\n{stdout}{stderr}"
    );
    let mut results = BTreeMap::new();
    let mut mutations = Vec::new();
    for line in stdout.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["FORMAL", name, rest @ ..] => {
                results.insert(name.to_string(), rest.join(" "));
            }
            ["MUTATION", name, mutation, rest @ ..] => {
                mutations.push((name.to_string(), mutation.to_string(), rest.join(" ")));
            }
            _ => {}
        }
    }
    FormalRun { results, mutations }
}

fn property_files() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(workspace().join("formal"))
        .unwrap()
        .filter_map(|entry| {
            let path = entry.unwrap().path();
            (path.extension()? == "sv").then(|| path.file_stem()?.to_str().map(str::to_string))?
        })
        .collect();
    names.sort();
    names
}

/// docs/FORMAL.md's table: property → its "Result" column.
fn documented_results() -> BTreeMap<String, String> {
    let doc = std::fs::read_to_string(workspace().join("docs/FORMAL.md")).unwrap();
    doc.lines()
        .filter_map(|line| {
            let cells: Vec<&str> = line.split('|').map(str::trim).collect();
            let name = cells
                .get(1)?
                .strip_prefix("`formal/")?
                .strip_suffix(".sv`")?;
            Some((name.to_string(), cells.get(4)?.to_string()))
        })
        .collect()
}

/// Every property file has a row in docs/FORMAL.md, holds as that row says, and lists mutations,
/// each of whose outcome starts with `expected`.
fn check_run(run: &FormalRun, expected: &str) {
    let files = property_files();
    let documented = documented_results();
    for name in &files {
        let result = run
            .results
            .get(name)
            .unwrap_or_else(|| panic!("formal/{name}.sv was not run"));
        let claim = documented
            .get(name)
            .unwrap_or_else(|| panic!("docs/FORMAL.md has no row for formal/{name}.sv"));
        if claim.starts_with("proved") {
            assert!(
                result.starts_with("proved for every depth"),
                "{name}: docs/FORMAL.md says `{claim}`, the run says `{result}`"
            );
        } else {
            let bound: String = claim
                .chars()
                .skip_while(|c| !c.is_ascii_digit())
                .take_while(char::is_ascii_digit)
                .collect();
            assert!(
                result.starts_with(&format!("bounded: holds for {bound} steps")),
                "{name}: docs/FORMAL.md says `{claim}`, the run says `{result}`"
            );
        }
        let broken: Vec<_> = run.mutations.iter().filter(|(p, _, _)| p == name).collect();
        assert!(
            !broken.is_empty(),
            "formal/{name}.sv lists no mutation: nothing shows its proof can fail"
        );
        for (_, mutation, outcome) in broken {
            assert!(
                outcome.starts_with(expected),
                "{name}: mutation {mutation}: {outcome}"
            );
        }
    }
    assert_eq!(
        documented.keys().cloned().collect::<Vec<_>>(),
        files,
        "docs/FORMAL.md lists exactly the property files"
    );
}

#[test]
fn every_property_holds_and_every_mutation_applies() {
    check_run(&run_formal("--mutation-texts"), "applies");
}

#[test]
#[ignore = "minutes: make formal"]
fn every_property_holds_and_every_mutation_breaks_its_proof() {
    check_run(&run_formal("--mutations"), "caught: FAIL");
}

#[test]
fn harness_state_encodings_match_the_verilog() {
    let verilog: String = [
        "can_controller.v",
        "can_controller_wb.v",
        "can_controller_axil.v",
        "can_controller_apb.v",
    ]
    .iter()
    .map(|file| std::fs::read_to_string(workspace().join("fpga/rtl").join(file)).unwrap())
    .collect();
    let encodings = std::fs::read_to_string(workspace().join("formal/encodings.vh")).unwrap();
    let mut checked = 0;
    for line in encodings.lines().filter(|l| l.starts_with("`define")) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let (name, value) = (words[1], words[2]);
        let (enumeration, variant) = name.split_once('_').expect("Enum_Variant");
        let number = value.split_once("'d").map_or(value, |(_, n)| n);
        let declaration = format!("localparam {enumeration}${variant} = {number};");
        assert!(
            verilog.contains(&declaration),
            "formal/encodings.vh: {name} = {value}, but fpga/rtl has no `{declaration}`"
        );
        checked += 1;
    }
    assert!(checked >= 20, "{checked} encodings checked");
}
