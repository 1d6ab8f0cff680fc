//! The word-level netlist Yosys writes with `write_json` (after `proc; flatten; opt; memory -nomap`),
//! read into cells whose ports are lists of bits: either a constant or a numbered net.
//!
//! Only what the code generator needs is kept: the module's ports, its cells with their parameters
//! and connections, and the `init` values Yosys records on the nets of flip-flop outputs.

use std::collections::{BTreeMap, HashMap};

use serde_json::Value;

/// One bit of a connection.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Bit {
    /// A constant; Yosys's `x` and `z` read as 0 (the design never relies on them: every register
    /// has an initial value and the netlist has no tri-state).
    Const(bool),
    /// A net, by Yosys's number.
    Net(u64),
}

/// A cell of the netlist.
#[derive(Clone, Debug)]
pub(crate) struct Cell {
    /// Yosys's name of the cell (for the generated comments and error messages).
    pub name: String,
    /// Cell type without the `$`: `add`, `mux`, `sdffe`, `mem_v2`…
    pub kind: String,
    /// Parameters as Yosys writes them: binary strings, most significant bit first.
    params: BTreeMap<String, String>,
    /// Port name to bits, least significant first.
    pub connections: BTreeMap<String, Vec<Bit>>,
    /// The source lines Yosys records for the cell (the statement, and the instances it sits in).
    pub src_lines: Vec<u32>,
}

impl Cell {
    /// Parameter `name` as a number (`x` bits read as 0).
    pub fn param(&self, name: &str) -> Result<u64, String> {
        let text = self
            .params
            .get(name)
            .ok_or_else(|| format!("cell {} ({}) has no parameter {name}", self.name, self.kind))?;
        Ok(text
            .chars()
            .filter(|c| matches!(c, '0' | '1' | 'x' | 'z'))
            .fold(0u64, |acc, c| acc << 1 | u64::from(c == '1')))
    }

    /// Parameter `name` as bits, least significant first (`x` bits read as 0).
    pub fn param_bits(&self, name: &str) -> Result<Vec<bool>, String> {
        let text = self
            .params
            .get(name)
            .ok_or_else(|| format!("cell {} ({}) has no parameter {name}", self.name, self.kind))?;
        Ok(text.chars().rev().map(|c| c == '1').collect())
    }

    /// Parameter `name` is 1, or absent (then `default`).
    pub fn flag(&self, name: &str, default: bool) -> Result<bool, String> {
        if self.params.contains_key(name) {
            Ok(self.param(name)? != 0)
        } else {
            Ok(default)
        }
    }

    /// The bits of port `port`.
    pub fn port(&self, port: &str) -> Result<&[Bit], String> {
        self.connections
            .get(port)
            .map(Vec::as_slice)
            .ok_or_else(|| format!("cell {} ({}) has no port {port}", self.name, self.kind))
    }
}

/// The top module of a Yosys JSON netlist.
#[derive(Debug)]
pub(crate) struct Netlist {
    /// Input ports: name and bits.
    pub inputs: Vec<(String, Vec<Bit>)>,
    /// Output ports: name and bits.
    pub outputs: Vec<(String, Vec<Bit>)>,
    /// Cells, sorted by name (so the generated code does not depend on Yosys's hash order).
    pub cells: Vec<Cell>,
    /// Named nets: name to bits.
    pub names: BTreeMap<String, Vec<Bit>>,
    /// The power-up value of nets that carry an `init` attribute (flip-flop outputs).
    pub init: HashMap<u64, bool>,
}

impl Netlist {
    /// Reads module `top` of the JSON text Yosys wrote.
    pub fn parse(json: &str, top: &str) -> Result<Netlist, String> {
        let doc: Value =
            serde_json::from_str(json).map_err(|e| format!("the Yosys netlist: {e}"))?;
        let module = doc
            .get("modules")
            .and_then(|m| m.get(top))
            .ok_or_else(|| format!("the Yosys netlist has no module {top}"))?;
        let mut netlist = Netlist {
            inputs: Vec::new(),
            outputs: Vec::new(),
            cells: Vec::new(),
            names: BTreeMap::new(),
            init: HashMap::new(),
        };
        for (name, port) in object(module, "ports")? {
            let bits = bits(&port["bits"])?;
            match port["direction"].as_str() {
                Some("input") => netlist.inputs.push((name.clone(), bits)),
                Some("output") => netlist.outputs.push((name.clone(), bits)),
                other => return Err(format!("port {name} has direction {other:?}")),
            }
        }
        for (name, cell) in object(module, "cells")? {
            let kind = cell["type"].as_str().unwrap_or_default();
            let params = object(cell, "parameters")?
                .iter()
                .map(|(k, v)| (k.clone(), v.as_str().unwrap_or_default().to_string()))
                .collect();
            let mut connections = BTreeMap::new();
            for (port, value) in object(cell, "connections")? {
                connections.insert(port.clone(), bits(value)?);
            }
            let src_lines = cell["attributes"]["src"]
                .as_str()
                .unwrap_or_default()
                .split('|')
                .filter_map(|place| place.split(':').nth(1)?.split('.').next()?.parse().ok())
                .collect();
            netlist.cells.push(Cell {
                src_lines,
                name: name.clone(),
                kind: kind.trim_start_matches('$').to_string(),
                params,
                connections,
            });
        }
        netlist.cells.sort_by(|a, b| a.name.cmp(&b.name));
        for (name, net) in object(module, "netnames")? {
            let net_bits = bits(&net["bits"])?;
            if let Some(init) = net["attributes"]["init"].as_str() {
                for (bit, value) in net_bits.iter().zip(init.chars().rev()) {
                    if let Bit::Net(n) = bit {
                        netlist.init.insert(*n, value == '1');
                    }
                }
            }
            netlist.names.insert(name.clone(), net_bits);
        }
        Ok(netlist)
    }
}

fn object<'a>(value: &'a Value, key: &str) -> Result<&'a serde_json::Map<String, Value>, String> {
    value[key]
        .as_object()
        .ok_or_else(|| format!("the Yosys netlist has no object `{key}`"))
}

fn bits(value: &Value) -> Result<Vec<Bit>, String> {
    let list = value
        .as_array()
        .ok_or_else(|| format!("bits are not a list: {value}"))?;
    list.iter()
        .map(|b| match b {
            Value::Number(n) => n
                .as_u64()
                .map(Bit::Net)
                .ok_or_else(|| format!("net number {n}")),
            Value::String(s) => Ok(Bit::Const(s == "1")),
            other => Err(format!("bit {other}")),
        })
        .collect()
}
