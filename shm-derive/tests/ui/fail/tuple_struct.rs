#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Pair(u32, u32);

fn main() {}
