use shm_cdr::RosMessage;

#[derive(RosMessage)]
#[ros(package = "ui_msgs")]
struct Inner {
    x: f64,
}

#[derive(RosMessage)]
#[ros(package = "ui_msgs", loan)]
struct Outer {
    inner: Inner,
    values: Vec<f32>,
}

#[derive(RosMessage)]
#[ros(package = "ui_msgs", loan)]
struct Borrowing<'a> {
    name: &'a str,
}

fn main() {}
