#[derive(shm_cdr::RosMessage)]
#[ros(type_name = "ui_msgs/msg/Sample", source_encoding = "yaml")]
struct Sample {
    a: u8,
}

#[derive(shm_cdr::RosMessage)]
#[ros(type_name = "ui_msgs/srv/Other_Request", source_encoding = "implicit", source = "uint8 a")]
struct Other {
    #[ros(default_value = 3)]
    a: u8,
}

fn main() {}
