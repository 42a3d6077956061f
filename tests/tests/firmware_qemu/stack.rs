//! The task is built in place in its static (issue 71, docs/firmware.md
//! "Measured"): the start-up stack stays small whatever the cells.

use super::harness::*;

/// The deepest stack before the sample loop (`stack_init_bytes`: the
/// board's start-up and the task's initialisation in its static) is at
/// most 12 KiB for the default one-cell image (`firmware/data/cell-pulse.csv`)
/// and for a 16-cell pack made from it (`--cells 16`), while the task is
/// far larger than that (32 KB and 60 KB): a copy of the task on the
/// stack, as when it was built by value and moved into its static
/// (43 736 and 141 992 B), fails the test. Measured: 992 and 1 000 B.
#[test]
fn qemu_task_is_built_in_its_static_for_1_and_16_cells() {
    const LIMIT: u64 = 12 * 1024;
    let input = root().join("firmware/data/cell-pulse.csv");
    for cells in [1u64, 16] {
        let args: &[&str] = if cells == 1 { &[] } else { &["--cells", "16"] };
        let fw = firmware(&input, args);
        eprintln!("{cells} cell(s): {fw}");
        let init = fw["stack_init_bytes"].as_u64().expect("stack_init_bytes");
        let task = fw["task_bytes"].as_u64().expect("task_bytes");
        match fw["cells"].as_array() {
            Some(c) => assert_eq!(c.len() as u64, cells, "{fw}"),
            None => assert_eq!(cells, 1, "{fw}"),
        }
        assert!(task > 2 * LIMIT, "{cells} cell(s): task {task} B");
        assert!(
            init <= LIMIT,
            "{cells} cell(s): {init} B of stack at start-up (task {task} B): \
             the task is built on the stack again"
        );
    }
}
