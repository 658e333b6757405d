//! Decoding never allocates more than the input can justify: measured with a
//! counting global allocator over hostile inputs whose length prefixes claim
//! billions of elements.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use shm_cdr::{from_bytes, RosMessage};
use shm_cdr_tests::msgs::{JointState, PointCloud2, PoseArray};

struct Counting;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards every call unchanged to the system allocator; it only records
// the largest size requested.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: same layout contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[derive(RosMessage, Debug)]
#[ros(package = "alloc_test")]
struct Lists {
    names: Vec<String>,
    values: Vec<f64>,
    nested: Vec<PoseArray>,
}

/// The largest single allocation made while decoding `input` as `T`.
fn largest_allocation<T: shm_cdr::DecodeOwned>(input: &[u8]) -> usize {
    LARGEST.store(0, Ordering::Relaxed);
    let _ = from_bytes::<T>(input);
    LARGEST.load(Ordering::Relaxed)
}

fn hostile_inputs() -> Vec<Vec<u8>> {
    let mut inputs = Vec::new();
    for prefix_at in [4usize, 8, 12, 16, 20, 24, 28, 32] {
        for claim in [u32::MAX, 0x1000_0000, 65_536, 1_000] {
            let mut input = vec![0u8; 64];
            input[..4].copy_from_slice(&[0, 1, 0, 0]);
            input[prefix_at..prefix_at + 4].copy_from_slice(&claim.to_le_bytes());
            inputs.push(input);
        }
    }
    // A 4-byte body that is all length prefix.
    inputs.push(vec![0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff]);
    inputs
}

#[test]
fn hostile_length_prefixes_allocate_at_most_a_few_times_the_input() {
    for input in hostile_inputs() {
        // Each element in memory is at most 56 bytes (a Pose) per wire byte of
        // its minimum size; the input justifies no more than that.
        let limit = 64 * input.len();
        for (name, largest) in [
            ("Lists", largest_allocation::<Lists>(&input)),
            ("PointCloud2", largest_allocation::<PointCloud2>(&input)),
            ("JointState", largest_allocation::<JointState>(&input)),
            ("PoseArray", largest_allocation::<PoseArray>(&input)),
        ] {
            assert!(
                largest <= limit,
                "{name}: a {}-byte input caused a {largest}-byte allocation",
                input.len()
            );
        }
    }
}
