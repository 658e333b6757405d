#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
union Bits {
    a: u32,
    b: f32,
}

fn main() {}
