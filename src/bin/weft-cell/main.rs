//! weft-cell: the offline half. (to be written)
fn main() {}
