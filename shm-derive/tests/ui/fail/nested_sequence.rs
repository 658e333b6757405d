#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Grid {
    rows: Vec<Vec<f64>>,
}

fn main() {}
