//! The `softbench` command line.
fn main() {}
