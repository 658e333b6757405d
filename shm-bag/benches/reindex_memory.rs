//! Memory and time of `bag reindex` on a recording cut by `kill -9`: a file
//! of the given size (1 MiB chunks of 64 KiB messages, the last chunk
//! unfinished) is written to disk, then reindexed. Printed: the file's size,
//! the reindex's peak resident memory above what the process held before it
//! (from `VmHWM`, reset first), its ratio to the file size, and the time
//! beside a plain copy of the same file in the same run (`std::fs::copy`,
//! the least a rewrite costs).
//!
//! ```text
//! cargo bench -p shm-bag --bench reindex_memory                    # 2048 MiB in the temporary directory
//! SHM_BAG_BENCH_MB=512 SHM_BAG_BENCH_DIR=/var/tmp cargo bench -p shm-bag --bench reindex_memory
//! ```

use std::path::Path;
use std::time::Instant;

use shm_bag::metadata::TopicMetadata;
use shm_bag::{reindex, BagWriter, WriteOptions};

const MESSAGE: usize = 64 * 1024;

/// A memory figure of this process's `/proc/self/status` (`VmHWM`,
/// `VmRSS`), in bytes.
fn status_bytes(field: &str) -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// Start measuring the peak anew (Linux: `5` to `clear_refs`).
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// A bag in `dir` whose recording was killed after `bytes` of messages.
fn cut_recording(dir: &Path, bytes: u64) {
    let mut writer = BagWriter::create(dir, WriteOptions::default()).expect("a bag");
    let topic = TopicMetadata {
        name: "/points".to_owned(),
        type_name: "std_msgs/msg/String".to_owned(),
        serialization_format: "cdr".to_owned(),
        offered_qos_profiles: Vec::new(),
        type_description_hash: String::new(),
    };
    let id = writer.add_topic(topic, String::new()).expect("a topic");
    let mut data = vec![0x5a; MESSAGE];
    data[..4].copy_from_slice(&[0, 1, 0, 0]);
    let count = bytes / MESSAGE as u64;
    for i in 0..count {
        writer
            .write(id, 1_000 + i, 1_000 + i, i as u32, &data)
            .expect("a write");
        if i % 4096 == 4095 {
            writer.flush().expect("a flush");
        }
    }
    writer.flush().expect("a flush");
    // One more message in an open chunk, then the process dies.
    writer
        .write(id, 1_000 + count, 0, count as u32, &data)
        .expect("a write");
    std::mem::forget(writer);
}

fn main() {
    let mb: u64 = std::env::var("SHM_BAG_BENCH_MB")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2048);
    let base = std::env::var_os("SHM_BAG_BENCH_DIR")
        .map_or_else(std::env::temp_dir, Into::into)
        .join(format!("shm_bag_reindex_bench_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let dir = base.join("bag");
    cut_recording(&dir, mb << 20);
    let file = std::fs::read_dir(&dir)
        .expect("the bag")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "mcap"))
        .expect("an MCAP file");
    let size = std::fs::metadata(&file).expect("its size").len();

    let start = Instant::now();
    std::fs::copy(&file, base.join("copy.mcap")).expect("a copy");
    let copy_time = start.elapsed();
    let _ = std::fs::remove_file(base.join("copy.mcap"));

    let before = status_bytes("VmRSS");
    let peak_measured = reset_peak();
    let start = Instant::now();
    let done = reindex(&dir).expect("reindex");
    let reindex_time = start.elapsed();
    let above = status_bytes("VmHWM").saturating_sub(before);
    let report = &done.files[0];
    println!(
        "file {:.0} MiB, {} messages recovered ({} chunks damaged)",
        size as f64 / 1048576.0,
        report.messages,
        report.damaged_chunks
    );
    if peak_measured {
        println!(
            "reindex peak resident memory above the start: {:.1} MiB ({:.4} of the file)",
            above as f64 / 1048576.0,
            above as f64 / size as f64
        );
    } else {
        println!("peak resident memory not measurable here (no /proc/self/clear_refs)");
    }
    println!(
        "reindex {:.2} s ({:.0} MB/s); std::fs::copy of the same file {:.2} s ({:.0} MB/s); ratio {:.2}",
        reindex_time.as_secs_f64(),
        size as f64 / 1e6 / reindex_time.as_secs_f64(),
        copy_time.as_secs_f64(),
        size as f64 / 1e6 / copy_time.as_secs_f64(),
        reindex_time.as_secs_f64() / copy_time.as_secs_f64()
    );
    let _ = std::fs::remove_dir_all(&base);
}
