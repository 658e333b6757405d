#[derive(shm_cdr::RosMessage)]
#[ros(type_name = "Reading")]
struct Reading {
    value: f64,
}

#[derive(shm_cdr::RosMessage)]
#[ros(type_name = "MyPkg/msg/Reading")]
struct Upper {
    value: f64,
}

#[derive(shm_cdr::RosMessage)]
#[ros(package = "my_pkg")]
#[allow(non_snake_case)]
struct Fields {
    frameId: u32,
    #[ros(rename = "trailing_")]
    ok: u32,
}

fn main() {}
