#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Sample {
    #[ros(byte)]
    value: f64,
}

fn main() {}
