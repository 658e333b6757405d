#[derive(shm_cdr::RosMessage)]
#[ros(type_name = "ui_msgs/msg/Sample", package = "ui_msgs", colour = "red")]
#[ros(char)]
struct Sample {
    #[ros(byte, char)]
    a: u8,
    #[ros(type_name = "x/msg/Y")]
    b: u8,
    #[ros(unknown)]
    c: u8,
}

fn main() {}
