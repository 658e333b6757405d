// A mistake in a message type is reported once, at the mistake: the uses of
// the type add nothing.
#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Reading {
    id: usize,
    value: f64,
}

fn main() {
    let reading = Reading { id: 1, value: 2.0 };
    let _ = shm_cdr::to_vec(&reading);
    let _ = shm_cdr::from_bytes::<Reading>(&[]);
    let _ = <Reading as shm_cdr::RosMessage>::type_hash();
}
