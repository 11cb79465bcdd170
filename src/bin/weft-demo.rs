//! The demo (grows with each issue).
fn main() {}
