//! `translucent`: the command line (DESIGN section 8).
fn main() {}
