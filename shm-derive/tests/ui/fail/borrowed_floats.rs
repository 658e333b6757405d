#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Cloud<'a> {
    points: &'a [f64],
    name: &'a String,
}

fn main() {}
