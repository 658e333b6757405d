//! Messages typed at run time (`shm_cdr::dynamic`) against the generated code
//! for the same message, measured in the same run: the borrowed decode (the
//! dynamic one built as a `Message`, or checked as a `MessageView`, then every
//! field of the view read) and `encode_into` of each.
//!
//! `cargo bench -p shm-cdr-tests --bench dynamic`, then
//! `python3 tests/benches/report.py` prints the ratios (medians).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use shm_cdr::dynamic::{DynamicType, FieldView, StructView};
use shm_cdr::msgs::sensor_msgs::ImuRef;
use shm_cdr::{encode_into, encoded_size, from_bytes, to_vec, CdrEncode, RosMessage};
use shm_cdr_tests::msgs::{JointStateRef, PointCloud2Ref, StringListRef};
use shm_cdr_tests::samples;

fn bench_pair<T: RosMessage>(c: &mut Criterion, name: &str, msg: &T, decode_generated: fn(&[u8])) {
    let size = encoded_size(msg);
    let bytes = to_vec(msg).unwrap();
    let ty = DynamicType::from_description(&T::full_description()).unwrap();
    let dynamic = ty.decode(&bytes).unwrap();
    assert_eq!(to_vec(&dynamic).unwrap(), bytes);
    let mut dst = vec![0u8; size];

    let mut group = c.benchmark_group(format!("dynamic {name}"));
    group.throughput(Throughput::Bytes(size as u64));
    group.bench_function(BenchmarkId::new("generated_decode_borrowed", size), |b| {
        b.iter(|| decode_generated(black_box(&bytes)))
    });
    group.bench_function(BenchmarkId::new("dynamic_decode", size), |b| {
        b.iter(|| black_box(ty.decode(black_box(&bytes)).unwrap()))
    });
    group.bench_function(BenchmarkId::new("dynamic_view", size), |b| {
        b.iter(|| black_box(ty.view(black_box(&bytes)).unwrap()))
    });
    group.bench_function(BenchmarkId::new("dynamic_view_read_all", size), |b| {
        b.iter(|| black_box(read_all(&ty.view(black_box(&bytes)).unwrap().root())))
    });
    group.bench_function(BenchmarkId::new("generated_encode_into", size), |b| {
        b.iter(|| encode_into(black_box(msg), &mut dst).unwrap())
    });
    group.bench_function(BenchmarkId::new("dynamic_encode_into", size), |b| {
        b.iter(|| encode_into(black_box(&dynamic), &mut dst).unwrap())
    });
    group.finish();
}

/// Read every field of a view, nested messages included: what a reader of
/// the whole message does after the view has checked it. Returns how many
/// values were read.
fn read_all(message: &StructView<'_, '_>) -> usize {
    message
        .fields()
        .map(|(_, field)| match field {
            FieldView::Value(value) => {
                black_box(value.read().unwrap());
                1
            }
            FieldView::Message(nested) => read_all(&nested),
            FieldView::Messages(nested) => nested.iter().map(|m| read_all(&m)).sum(),
        })
        .sum()
}

fn pairs(c: &mut Criterion) {
    fn cloud(bytes: &[u8]) {
        black_box(from_bytes::<PointCloud2Ref>(bytes).unwrap());
    }
    fn joints(bytes: &[u8]) {
        black_box(from_bytes::<JointStateRef>(bytes).unwrap());
    }
    fn imu(bytes: &[u8]) {
        black_box(from_bytes::<ImuRef>(bytes).unwrap());
    }
    fn strings(bytes: &[u8]) {
        black_box(from_bytes::<StringListRef>(bytes).unwrap());
    }
    bench_pair(c, "PointCloud2 1MiB", &samples::point_cloud(1 << 20), cloud);
    bench_pair(c, "Imu", &samples::imu(), imu);
    bench_pair(c, "JointState 40", &samples::joint_state(40), joints);
    bench_pair(c, "StringList 1000", &samples::string_list(1000), strings);
}

// `CdrEncode` is what `encode_into` takes: the dynamic message implements it.
const _: fn() = || {
    fn encodes<T: CdrEncode>() {}
    encodes::<shm_cdr::dynamic::Message<'static>>();
};

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(40)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = pairs
}
criterion_main!(benches);
