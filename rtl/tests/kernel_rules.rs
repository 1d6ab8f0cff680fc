//! The kernels follow the rules the activity-driven settle relies on (`rtl::activity`): they never
//! read a child's input, and they only pass the clock on. A kernel that broke one would still
//! simulate, but could be skipped while a value it reads changes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A block of the crate: its file, and its fields with their types.
struct Block {
    file: PathBuf,
    fields: Vec<(String, String)>,
}

fn sources() -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut dirs = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join("src")];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// Every `#[derive(ActivityBlock…)]` struct, by name.
fn blocks() -> BTreeMap<String, Block> {
    let mut blocks = BTreeMap::new();
    for file in sources() {
        let text = std::fs::read_to_string(&file).unwrap();
        let mut rest = text.as_str();
        while let Some(at) = rest.find("#[derive(ActivityBlock") {
            rest = &rest[at..];
            let header = rest.find("pub struct ").unwrap() + "pub struct ".len();
            let name: String = rest[header..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            let body_start = rest.find("{\n").unwrap() + 2;
            let body_end = rest.find("\n}").unwrap();
            let fields = rest[body_start..body_end]
                .lines()
                .map(str::trim)
                .filter(|l| !l.starts_with("//") && l.contains(": "))
                .map(|l| {
                    let l = l.trim_start_matches("pub ").trim_end_matches(',');
                    let (field, ty) = l.split_once(": ").unwrap();
                    (field.to_string(), ty.to_string())
                })
                .collect();
            blocks.insert(
                name,
                Block {
                    file: file.clone(),
                    fields,
                },
            );
            rest = &rest[body_end..];
        }
    }
    blocks
}

/// The input ports of a child of type `ty` (the crate's blocks and rust-hdl's RAM).
fn inputs_of(blocks: &BTreeMap<String, Block>, ty: &str) -> Vec<String> {
    let name: String = ty.chars().take_while(|c| c.is_alphanumeric()).collect();
    if name == "RAM" {
        return [
            "read_address",
            "write_address",
            "write_data",
            "write_enable",
        ]
        .map(String::from)
        .to_vec();
    }
    blocks.get(&name).map_or_else(Vec::new, |b| {
        b.fields
            .iter()
            .filter(|(_, t)| t.starts_with("Signal<In,"))
            .map(|(f, _)| f.clone())
            .collect()
    })
}

/// The places in `text` (as "file:line: line") where `needle` occurs.
fn occurrences(file: &Path, text: &str, needle: &str) -> Vec<String> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.contains(needle))
        .map(|(k, l)| format!("{}:{}: {}", file.display(), k + 1, l.trim()))
        .collect()
}

#[test]
fn the_blocks_are_found() {
    let blocks = blocks();
    for name in [
        "CanController",
        "CanCore",
        "Protocol",
        "BitTiming",
        "RxFifo",
    ] {
        assert!(blocks.contains_key(name), "{name} not found");
    }
    // The parser sees the fields with their types: ports, children and registers.
    let controller = &blocks["CanController"].fields;
    for (field, ty) in [
        ("rdata", "Signal<Out, Bits<8>>"),
        ("interrupts", "Interrupts"),
        ("tbs", "DFF<Bit>"),
    ] {
        assert!(
            controller.iter().any(|(f, t)| f == field && t == ty),
            "CanController.{field}: {ty} not found"
        );
    }
}

#[test]
fn no_kernel_reads_an_input_of_a_child() {
    let blocks = blocks();
    let mut found = Vec::new();
    for block in blocks.values() {
        let text = std::fs::read_to_string(&block.file).unwrap();
        for (child, ty) in &block.fields {
            for input in inputs_of(&blocks, ty) {
                found.extend(occurrences(
                    &block.file,
                    &text,
                    &format!("self.{child}.{input}.val()"),
                ));
            }
        }
    }
    assert!(
        found.is_empty(),
        "a kernel reads an input of a child (keep the value in a Local):\n{}",
        found.join("\n")
    );
}

#[test]
fn kernels_only_pass_the_clock_on() {
    let mut found = Vec::new();
    for block in blocks().values() {
        let text = std::fs::read_to_string(&block.file).unwrap();
        for line in occurrences(&block.file, &text, "self.clock.val()") {
            if !line.contains("clock.next = self.clock.val()") {
                found.push(line);
            }
        }
        for edge in ["pos_edge()", "neg_edge()"] {
            found.extend(occurrences(&block.file, &text, edge));
        }
    }
    assert!(
        found.is_empty(),
        "a kernel uses the clock as data:\n{}",
        found.join("\n")
    );
}
