//! Generates `robot_interfaces` (examples/interfaces/) with shm-codegen: the
//! same generator as the standard set, run the way a user's crate runs it.

fn main() {
    shm_codegen::Builder::new()
        .package("interfaces/robot_interfaces")
        .write_to_out_dir("robot_interfaces.rs")
        .unwrap_or_else(|e| panic!("{e}"));
}
