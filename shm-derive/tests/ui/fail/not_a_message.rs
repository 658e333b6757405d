struct Plain {
    x: f64,
}

#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Holder {
    inner: Plain,
}

fn main() {}
