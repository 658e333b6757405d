//! A message printed as JSON straight from its CDR bytes
//! (`DynamicType::serialize_cdr`, what `shm-ros2 topic echo --json` writes)
//! is the JSON of the decoded message, in either byte order, and takes
//! memory independent of the message's size and shape: measured with a
//! counting global allocator that follows the bytes alive.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::{sensor_msgs, std_msgs, test_msgs};
use shm_cdr::Endianness;
use shm_cdr::RosMessage;

struct Counting;

static ALIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(by: usize) {
    let now = ALIVE.fetch_add(by, Ordering::Relaxed) + by;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: forwards every call unchanged to the system allocator; it only
// counts the bytes handed out and not yet returned.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        // SAFETY: same layout contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        ALIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        grew(new_size);
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The most bytes alive at once while `run` runs, above those alive before.
fn peak_during(run: impl FnOnce()) -> usize {
    let before = ALIVE.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    run();
    PEAK.load(Ordering::Relaxed).saturating_sub(before)
}

#[derive(Debug, Clone, Default, PartialEq, RosMessage)]
#[ros(type_name = "grid_msgs/msg/Cell")]
struct Cell {
    v: u8,
}

#[derive(Debug, Clone, Default, PartialEq, RosMessage)]
#[ros(type_name = "grid_msgs/msg/Tagged")]
struct Tagged {
    v: u8,
    tags: Vec<String>,
    empty: test_msgs::msg::Empty,
}

#[derive(Debug, Clone, Default, PartialEq, RosMessage)]
#[ros(type_name = "grid_msgs/msg/Grid")]
struct Grid {
    cells: Vec<Cell>,
    tagged: Vec<Tagged>,
    names: Vec<String>,
    fixed: [Tagged; 2],
    data: Vec<u8>,
    values: Vec<f32>,
    label: String,
}

fn dynamic<T: RosMessage>() -> DynamicType {
    DynamicType::from_description(&T::full_description()).unwrap()
}

fn json_both_ways<T: RosMessage>(message: &T) {
    let ty = dynamic::<T>();
    for endianness in [Endianness::Little, Endianness::Big] {
        let bytes = shm_cdr::to_vec_with(message, endianness).unwrap();
        let decoded = serde_json::to_string(&ty.decode(&bytes).unwrap()).unwrap();
        for shared in [false, true] {
            let streamed =
                serde_json::to_string(&ty.serialize_cdr(&bytes, shared).unwrap()).unwrap();
            assert_eq!(streamed, decoded, "{} {endianness:?}", ty.name());
        }
    }
}

#[test]
fn streamed_json_is_the_decoded_messages_json() {
    let tagged = |i: usize| Tagged {
        v: i as u8,
        tags: (0..i % 4).map(|t| format!("t\"{t}")).collect(),
        empty: Default::default(),
    };
    json_both_ways(&Grid {
        cells: (0..300).map(|i| Cell { v: i as u8 }).collect(),
        tagged: (0..50).map(tagged).collect(),
        names: vec!["a".into(), "ü\n".into()],
        fixed: [tagged(1), tagged(3)],
        data: vec![1, 2, 3],
        values: vec![0.1, f32::NAN, -2.5],
        label: "label".into(),
    });
    json_both_ways(&sensor_msgs::PointCloud2 {
        data: (0..=255).collect(),
        fields: vec![Default::default(); 3],
        ..Default::default()
    });
    json_both_ways(&test_msgs::msg::Arrays::default());
    json_both_ways(&test_msgs::msg::WStrings {
        wstring_value: "wide ü".into(),
        ..Default::default()
    });
    json_both_ways(&std_msgs::Header::default());

    // Bad input is refused before anything is written.
    let ty = dynamic::<Grid>();
    let bytes = shm_cdr::to_vec(&Grid {
        names: vec!["x".into(); 10],
        ..Default::default()
    })
    .unwrap();
    assert!(ty.serialize_cdr(&bytes[..bytes.len() - 3], false).is_err());
    assert!(ty.serialize_cdr(&[0, 1], false).is_err());
}

#[test]
fn streamed_json_takes_memory_independent_of_the_messages_size() {
    let ty = dynamic::<Grid>();
    let grid = Grid {
        cells: vec![Cell { v: 7 }; 2 << 20],
        names: vec![String::new(); 100_000],
        ..Default::default()
    };
    let bytes = shm_cdr::to_vec(&grid).unwrap();
    drop(grid);
    let size = bytes.len();

    let streamed = peak_during(|| {
        let out = std::io::BufWriter::new(std::io::sink());
        serde_json::to_writer(out, &ty.serialize_cdr(&bytes, false).unwrap()).unwrap();
    });
    let decoded = peak_during(|| {
        let out = std::io::BufWriter::new(std::io::sink());
        serde_json::to_writer(out, &ty.decode(&bytes).unwrap()).unwrap();
    });
    eprintln!("{size} bytes: streamed {streamed}, decoded {decoded} bytes at most alive");
    // The decoded tree holds every one-byte cell as a message of its own.
    assert!(decoded > 4 * size, "decoded: {decoded} for {size} bytes");
    assert!(streamed < 64 << 10, "streamed: {streamed} for {size} bytes");
}
