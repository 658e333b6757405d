#[derive(shm_cdr::RosMessage)]
#[ros(package = "ui_msgs")]
struct Wrapper<T, const N: usize> {
    value: T,
    values: [u8; N],
}

fn main() {}
