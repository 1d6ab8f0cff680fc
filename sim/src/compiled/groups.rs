//! Cuts the netlist into the groups `eval` runs or skips: the cells (and the next-state logic of
//! flip-flops and memories) are put in one dependency order that stays inside one rust-hdl block
//! (Verilog module) as long as it can, and every run of one block's cells is a group. A group runs
//! after everything it reads, so a single pass in group order settles the logic.
//!
//! A cell's block is the deepest module among the source lines Yosys records for it; cells Yosys
//! made itself (without a source) join the block of a neighbour.

use std::collections::{BTreeMap, BTreeSet};

use super::emit::Interface;
use super::netlist::{Bit, Cell};

/// At most this many groups (the dirty set is a `u128` whose last bit stands for the output word);
/// adjacent groups are merged down to it.
const MAX_GROUPS: usize = 127;

/// What one step of the evaluation computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Item {
    /// Combinational cell `k`.
    Comb(usize),
    /// The next value of flip-flop `k`.
    Reg(usize),
    /// The read address and write of memory `k`.
    Mem(usize),
}

/// The groups, in evaluation order.
#[derive(Debug, Default)]
pub(crate) struct Groups {
    /// How many.
    pub count: usize,
    /// The block of each group (for the generated comments).
    pub names: Vec<String>,
    /// Each group's items in dependency order.
    pub items: Vec<Vec<Item>>,
    /// The group of each combinational cell, flip-flop and memory.
    pub of_comb: Vec<usize>,
    pub of_reg: Vec<usize>,
    pub of_mem: Vec<usize>,
    /// The variables each group reads (filled in by the emitter, which knows the variables).
    pub reads: Vec<BTreeSet<usize>>,
}

/// Groups the cells; `comb_reads` gives the combinational cells a list of bits reads.
pub(crate) fn group_cells(
    comb: &[&Cell],
    regs: &[&Cell],
    mems: &[&Cell],
    comb_reads: impl Fn(&[Bit]) -> Vec<usize>,
    io: &Interface,
) -> Result<Groups, String> {
    let mut items: Vec<(Item, &Cell, &str)> = Vec::new();
    items.extend(
        comb.iter()
            .enumerate()
            .map(|(k, c)| (Item::Comb(k), *c, "Y")),
    );
    items.extend(
        regs.iter()
            .enumerate()
            .map(|(k, c)| (Item::Reg(k), *c, "Q")),
    );
    items.extend(
        mems.iter()
            .enumerate()
            .map(|(k, c)| (Item::Mem(k), *c, "RD_DATA")),
    );
    // deps[i]: the items (all combinational, the first comb.len()) item i reads.
    let deps: Vec<Vec<usize>> = items
        .iter()
        .map(|(_, cell, output)| {
            let mut d: Vec<usize> = cell
                .connections
                .iter()
                .filter(|(port, _)| port != output)
                .flat_map(|(_, bits)| comb_reads(bits))
                .collect();
            d.sort_unstable();
            d.dedup();
            d
        })
        .collect();
    let mut users: Vec<Vec<usize>> = vec![Vec::new(); items.len()];
    for (i, d) in deps.iter().enumerate() {
        for &on in d {
            users[on].push(i);
        }
    }
    let modules = Modules::of(io.verilog);
    let mut block: Vec<Option<String>> = items
        .iter()
        .map(|(_, cell, _)| modules.deepest(&cell.src_lines))
        .collect();
    adopt_neighbours(&mut block, &deps, &users);
    let block: Vec<String> = block
        .into_iter()
        .map(|b| b.unwrap_or_else(|| modules.top()))
        .collect();
    let order = dependency_order(&block, &deps, &users).ok_or_else(|| {
        "the netlist has a combinational loop (no dependency order exists)".to_string()
    })?;
    let mut runs: Vec<(String, Vec<usize>)> = Vec::new();
    for i in order {
        match runs.last_mut() {
            Some((name, list)) if *name == block[i] => list.push(i),
            _ => runs.push((block[i].clone(), vec![i])),
        }
    }
    merge_smallest_neighbours(&mut runs, MAX_GROUPS);
    let mut groups = Groups {
        count: runs.len(),
        of_comb: vec![0; comb.len()],
        of_reg: vec![0; regs.len()],
        of_mem: vec![0; mems.len()],
        ..Groups::default()
    };
    for (g, (name, list)) in runs.into_iter().enumerate() {
        groups.names.push(name);
        let mut group_items = Vec::with_capacity(list.len());
        for i in list {
            let item = items[i].0;
            match item {
                Item::Comb(k) => groups.of_comb[k] = g,
                Item::Reg(k) => groups.of_reg[k] = g,
                Item::Mem(k) => groups.of_mem[k] = g,
            }
            group_items.push(item);
        }
        groups.items.push(group_items);
    }
    Ok(groups)
}

/// Items without a block take the block of a cell they read or that reads them.
fn adopt_neighbours(block: &mut [Option<String>], deps: &[Vec<usize>], users: &[Vec<usize>]) {
    loop {
        let mut changed = false;
        for i in 0..block.len() {
            if block[i].is_none() {
                let neighbour = deps[i]
                    .iter()
                    .chain(&users[i])
                    .find_map(|&j| block[j].clone());
                if neighbour.is_some() {
                    block[i] = neighbour;
                    changed = true;
                }
            }
        }
        if !changed {
            return;
        }
    }
}

/// Kahn's algorithm that stays in the current block while it has a ready item, then moves to the
/// block with the most ready items (ties: the first name). `None` on a loop.
fn dependency_order(
    block: &[String],
    deps: &[Vec<usize>],
    users: &[Vec<usize>],
) -> Option<Vec<usize>> {
    let mut waiting: Vec<usize> = deps.iter().map(Vec::len).collect();
    let mut ready: BTreeMap<&str, BTreeSet<usize>> = BTreeMap::new();
    for (i, w) in waiting.iter().enumerate() {
        if *w == 0 {
            ready.entry(&block[i]).or_default().insert(i);
        }
    }
    let mut order = Vec::with_capacity(block.len());
    let mut current: Option<&str> = None;
    while order.len() < block.len() {
        let stay = current.is_some_and(|c| ready.get(c).is_some_and(|r| !r.is_empty()));
        if !stay {
            current = ready
                .iter()
                .filter(|(_, r)| !r.is_empty())
                .max_by(|a, b| a.1.len().cmp(&b.1.len()).then(b.0.cmp(a.0)))
                .map(|(name, _)| *name);
        }
        let i = ready.get_mut(current?)?.pop_first()?;
        order.push(i);
        for &user in &users[i] {
            waiting[user] -= 1;
            if waiting[user] == 0 {
                ready.entry(&block[user]).or_default().insert(user);
            }
        }
    }
    Some(order)
}

/// Merges adjacent runs (the smallest pair first) until at most `max` remain; the order of the
/// items does not change, so it stays a dependency order.
fn merge_smallest_neighbours(runs: &mut Vec<(String, Vec<usize>)>, max: usize) {
    while runs.len() > max {
        let at = (0..runs.len() - 1)
            .min_by_key(|&i| runs[i].1.len() + runs[i + 1].1.len())
            .expect("two runs");
        let (name, list) = runs.remove(at + 1);
        runs[at].0 = format!("{} + {name}", runs[at].0);
        runs[at].1.extend(list);
    }
}

/// The modules of the Verilog by their first line.
struct Modules(Vec<(u32, String)>);

impl Modules {
    fn of(verilog: &str) -> Modules {
        Modules(
            verilog
                .lines()
                .enumerate()
                .filter_map(|(i, line)| {
                    let name = line.strip_prefix("module ")?.split('(').next()?;
                    Some((i as u32 + 1, name.trim().to_string()))
                })
                .collect(),
        )
    }

    fn top(&self) -> String {
        self.0.first().map(|(_, n)| n.clone()).unwrap_or_default()
    }

    fn at(&self, line: u32) -> Option<&str> {
        let i = self.0.partition_point(|(start, _)| *start <= line);
        i.checked_sub(1).map(|i| self.0[i].1.as_str())
    }

    /// The deepest (most `$`-separated) module among the lines.
    fn deepest(&self, lines: &[u32]) -> Option<String> {
        lines
            .iter()
            .filter_map(|l| self.at(*l))
            .max_by_key(|name| name.matches('$').count())
            .map(str::to_string)
    }
}
