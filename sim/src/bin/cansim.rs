//! `cansim`: the command line tool of the CAN controller project.
fn main() {}
