//! Generates `rosbag2_interfaces` (the player's control services, as rosbag2
//! declares them) from `interfaces/` with shm-codegen.

fn main() {
    shm_codegen::Builder::new()
        .package("interfaces/rosbag2_interfaces")
        .write_to_out_dir("rosbag2_interfaces.rs")
        .unwrap_or_else(|e| panic!("{e}"));
}
