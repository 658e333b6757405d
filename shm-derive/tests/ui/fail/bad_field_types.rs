use std::collections::HashMap;

#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Wrong {
    count: usize,
    table: HashMap<String, u32>,
    maybe: Option<u32>,
    letter: char,
    big: u128,
    pair: (u32, f64),
    nested: Vec<isize>,
}

fn main() {}
