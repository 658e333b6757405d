use shm_cdr_peer_bench::messages::StringList;
use std::hint::black_box;
fn main() {
    let m = shm_cdr_peer_bench::samples::string_list().msg;
    let bytes = shm_cdr::to_vec(&m).unwrap();
    let n: u32 = std::env::var("N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5_000);
    for _ in 0..3 {
        let t = std::time::Instant::now();
        for _ in 0..n {
            black_box(shm_cdr::from_bytes::<StringList>(black_box(&bytes)).unwrap());
        }
        let c = t.elapsed().as_nanos() as f64 / f64::from(n);
        let t = std::time::Instant::now();
        for _ in 0..n {
            black_box(
                shm_cdr_peer_bench::peers::cdr_encoding::decode::<
                    shm_cdr_peer_bench::mirror::StringList,
                >(black_box(&bytes))
                .unwrap(),
            );
        }
        let d = t.elapsed().as_nanos() as f64 / f64::from(n);
        println!("ours {c:.1} cdr-encoding {d:.1}");
    }
}
