//! A message printed as JSON straight from its CDR bytes
//! (`DynamicType::serialize_cdr`, what `shm-ros2 topic echo --json` writes)
//! is the JSON of the decoded message, in either byte order; it, the
//! YAML `topic echo` prints (truncated, or with `--no-arr`) and one field
//! decoded alone (`--field`) take memory
//! independent of the message's size and shape: measured with a counting
//! global allocator that follows the bytes alive. The same allocator counts
//! the allocations of a decoded run-time typed message: one table per
//! message and per array of messages, not one per nested message.

use std::alloc::{GlobalAlloc, Layout, System};

use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::{sensor_msgs, std_msgs, test_msgs};
use shm_cdr::{Endianness, RosMessage};

struct Counting;

// Per thread, so that tests running beside one another do not count each
// other's allocations; what one thread frees of another's is counted where it
// is freed.
thread_local! {
    static ALIVE: std::cell::Cell<isize> = const { std::cell::Cell::new(0) };
    static PEAK: std::cell::Cell<isize> = const { std::cell::Cell::new(0) };
    static ALLOCATIONS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

fn grew(by: usize) {
    let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
    let by = isize::try_from(by).unwrap_or(isize::MAX);
    let _ = ALIVE.try_with(|alive| {
        let now = alive.get().saturating_add(by);
        alive.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

fn shrank(by: usize) {
    let by = isize::try_from(by).unwrap_or(isize::MAX);
    let _ = ALIVE.try_with(|alive| alive.set(alive.get().saturating_sub(by)));
}

// SAFETY: forwards every call unchanged to the system allocator; it only
// counts the bytes handed out and not yet returned, in thread-local cells
// that allocate nothing.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        // SAFETY: same layout contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        shrank(layout.size());
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        shrank(layout.size());
        grew(new_size);
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The most bytes this thread had alive at once while `run` ran, above
/// those alive before.
fn peak_during(run: impl FnOnce()) -> usize {
    let before = ALIVE.with(std::cell::Cell::get);
    PEAK.with(|peak| peak.set(before));
    run();
    usize::try_from(PEAK.with(std::cell::Cell::get).saturating_sub(before)).unwrap_or(0)
}

/// How many allocations (and reallocations) this thread made while `run`
/// ran.
fn allocations_during<T>(run: impl FnOnce() -> T) -> (usize, T) {
    let before = ALLOCATIONS.with(std::cell::Cell::get);
    let out = run();
    (ALLOCATIONS.with(std::cell::Cell::get) - before, out)
}

#[test]
fn a_decoded_message_allocates_a_table_per_message_and_per_array_of_messages() {
    use shm_cdr::dynamic::Value;
    use shm_cdr::msgs::geometry_msgs::{Pose, PoseArray};

    // A PointCloud2 nests a header, its stamp and four point fields: one
    // table for the message, one for the array of point fields and the box
    // that holds it. Strings and the points are borrowed from the input.
    let cloud = sensor_msgs::PointCloud2 {
        fields: ["x", "y", "z", "rgb"]
            .iter()
            .map(|name| sensor_msgs::PointField {
                name: (*name).into(),
                datatype: 7,
                count: 1,
                ..Default::default()
            })
            .collect(),
        data: vec![1; 4096],
        ..Default::default()
    };
    let bytes = shm_cdr::to_vec(&cloud).unwrap();
    let ty = DynamicType::from_description(&sensor_msgs::PointCloud2::full_description()).unwrap();
    let (n, message) = allocations_during(|| ty.decode(&bytes).unwrap());
    assert_eq!(n, 3, "allocations to decode a PointCloud2");
    assert_eq!(shm_cdr::to_vec(&message).unwrap(), bytes);

    // A thousand poses are one table of seven thousand numbers, which grows
    // once: a table starts at no more than 4096 slots, so that a count in
    // the input cannot make it large before the messages are read.
    let poses = PoseArray {
        poses: vec![Pose::default(); 1000],
        ..Default::default()
    };
    let bytes = shm_cdr::to_vec(&poses).unwrap();
    let ty = DynamicType::from_description(&PoseArray::full_description()).unwrap();
    let (n, message) = allocations_during(|| ty.decode(&bytes).unwrap());
    assert_eq!(n, 4, "allocations to decode 1000 poses");
    let Some(Value::Messages(decoded)) = message.value("poses") else {
        panic!("no poses")
    };
    assert_eq!(decoded.len(), 1000);
    assert_eq!(shm_cdr::to_vec(&message).unwrap(), bytes);
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

/// A 2.9 MB message of two million one-byte messages and 100 000 empty
/// strings: as small on the wire as a message of its shape can be.
fn two_million_cells() -> Vec<u8> {
    shm_cdr::to_vec(&Grid {
        cells: vec![Cell { v: 7 }; 2 << 20],
        names: vec![String::new(); 100_000],
        ..Default::default()
    })
    .unwrap()
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
    let bytes = two_million_cells();
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

#[test]
fn printed_yaml_takes_memory_independent_of_the_messages_size() {
    use shm_cdr::dynamic::YamlOptions;
    let ty = dynamic::<Grid>();
    let bytes = two_million_cells();
    let size = bytes.len();
    for (options, keep) in [
        (YamlOptions::echo(), 128),
        (YamlOptions::echo().no_arr(true), 0),
    ] {
        let mut text = String::new();
        let peak = peak_during(|| {
            text = ty
                .decode_truncated(&bytes, false, keep)
                .unwrap()
                .to_yaml_with(&options);
        });
        eprintln!(
            "{size} bytes: {peak} bytes at most alive printing {} bytes of YAML",
            text.len()
        );
        assert!(peak < 256 << 10, "{peak} bytes for {size}: {text}");
    }
}

#[test]
fn one_field_is_decoded_alone() {
    use shm_cdr::dynamic::Value;
    let ty = dynamic::<Grid>();
    let grid = Grid {
        cells: vec![Cell { v: 7 }; 2 << 20],
        fixed: [
            Tagged::default(),
            Tagged {
                v: 3,
                tags: vec!["x".into()],
                empty: Default::default(),
            },
        ],
        label: "the label".into(),
        ..Default::default()
    };
    let bytes = shm_cdr::to_vec(&grid).unwrap();
    let whole = ty.decode(&bytes).unwrap();
    for path in [&["label"][..], &["fixed"], &["data"], &["names"]] {
        assert_eq!(
            ty.decode_field(&bytes, false, path).unwrap().as_ref(),
            whole.value(path[0]),
            "{path:?}"
        );
    }
    assert_eq!(ty.decode_field(&bytes, true, &["nothing"]).unwrap(), None);
    assert!(ty
        .decode_field(&bytes[..bytes.len() - 2], false, &["label"])
        .is_err());
    drop(whole);
    let mut label = None;
    let peak = peak_during(|| label = ty.decode_field(&bytes, false, &["label"]).unwrap());
    eprintln!(
        "{} bytes: {peak} bytes at most alive decoding one field",
        bytes.len()
    );
    assert_eq!(label, Some(Value::String("the label".into())));
    assert!(peak < 64 << 10, "{peak}");
}
