//! The demo run: every node samples every bit right, and its VCD is a bus trace that sigrok's CAN
//! decoder reads frame by frame without a warning.

use sim::workloads::sync_demo::run_demo;
use testbenches::sigrok;

#[test]
fn demo_nodes_sample_every_bit_and_sigrok_decodes_every_frame() {
    let dir = std::env::temp_dir().join(format!("cansim-sync-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vcd = dir.join("demo.vcd");
    let report = run_demo(Some(&vcd)).expect("demo runs");
    assert!(report.all_bits_right(), "{report:#?}");
    assert_eq!(report.nodes.len(), 3);
    for node in &report.nodes {
        for f in &node.frames {
            assert_eq!(
                f.hard_syncs, 1,
                "{}: one hard sync per frame (SOF)",
                node.name
            );
        }
    }
    let moved = &report.nodes[0].frames[1];
    assert_eq!(
        moved.sample_after_edge_tq,
        Some(13.0),
        "3 tq late, SJW 2: sample 1 tq early"
    );
    assert!(vcd.exists() && !dir.join("demo.vcd.partial").exists());
    if sigrok::skipped() {
        return;
    }
    let decoded = sigrok::decode(&vcd, "bus", 500_000, 87.5);
    let sent: Vec<&str> = report.frames.iter().map(|(f, _)| f.as_str()).collect();
    assert_eq!(decoded.frames, sent);
    assert!(decoded.warnings.is_empty(), "{:?}", decoded.warnings);
    std::fs::remove_dir_all(&dir).ok();
}
