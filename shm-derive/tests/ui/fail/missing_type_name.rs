#[derive(shm_cdr::RosMessage)]
struct Reading {
    value: f64,
}

fn main() {}
