//! Encode, exact size and decode of realistic messages, next to a memcpy of the
//! same number of bytes measured in the same run (the physical reference).
//!
//! `cargo bench -p shm-cdr-tests --bench cdr`, then
//! `python3 tests/benches/report.py` prints the README table (medians).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use shm_cdr::{encode_into, encoded_size, from_bytes, to_vec, CdrEncode, DecodeOwned};
use shm_cdr_tests::msgs::{JointStateRef, PointCloud2Ref, PoseArray};
use shm_cdr_tests::samples;

/// `decode_borrowed` decodes the borrowing variant of the message type.
fn bench_message<Owned>(c: &mut Criterion, name: &str, msg: &Owned, decode_borrowed: fn(&[u8]))
where
    Owned: CdrEncode + DecodeOwned,
{
    let size = encoded_size(msg);
    let bytes = to_vec(msg).unwrap();
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Bytes(size as u64));

    let source = bytes.clone();
    let mut dst = vec![0u8; size];
    group.bench_function(BenchmarkId::new("memcpy", size), |b| {
        b.iter(|| dst.copy_from_slice(black_box(&source)))
    });
    group.bench_function(BenchmarkId::new("encode_into", size), |b| {
        b.iter(|| encode_into(black_box(msg), &mut dst).unwrap())
    });
    group.bench_function(BenchmarkId::new("to_vec", size), |b| {
        b.iter(|| to_vec(black_box(msg)).unwrap())
    });
    group.bench_function(BenchmarkId::new("encoded_size", size), |b| {
        b.iter(|| encoded_size(black_box(msg)))
    });
    group.bench_function(BenchmarkId::new("decode_owned", size), |b| {
        b.iter(|| from_bytes::<Owned>(black_box(&bytes)).unwrap())
    });
    group.bench_function(BenchmarkId::new("decode_borrowed", size), |b| {
        b.iter(|| decode_borrowed(black_box(&bytes)))
    });
    group.finish();
}

fn messages(c: &mut Criterion) {
    fn cloud_ref(bytes: &[u8]) {
        black_box(from_bytes::<PointCloud2Ref>(bytes).unwrap());
    }
    fn joints_ref(bytes: &[u8]) {
        black_box(from_bytes::<JointStateRef>(bytes).unwrap());
    }
    fn poses(bytes: &[u8]) {
        // Nothing in a PoseArray can be borrowed: the owned decode is the reference.
        black_box(from_bytes::<PoseArray>(bytes).unwrap());
    }
    bench_message(
        c,
        "PointCloud2 1MiB",
        &samples::point_cloud(1 << 20),
        cloud_ref,
    );
    bench_message(
        c,
        "PointCloud2 8MiB",
        &samples::point_cloud(8 << 20),
        cloud_ref,
    );
    bench_message(c, "JointState 40", &samples::joint_state(40), joints_ref);
    bench_message(c, "PoseArray 10k", &samples::pose_array(10_000), poses);
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(40)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = messages
}
criterion_main!(benches);
