#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
enum Mode {
    On,
    Off,
}

fn main() {}
