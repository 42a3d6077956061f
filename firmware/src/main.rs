//! Placeholder: the firmware arrives with its own issue.
fn main() {}
