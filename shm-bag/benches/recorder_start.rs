//! How soon a recording has its first message of a standard-type topic when
//! nodes that never answer `~/get_type_description` are present: a talker
//! publishes `/chatter` every millisecond, and `Recorder::start` is timed to
//! the first `/chatter` message written, with no silent node and with one
//! announcing 50 topics of its own types (its service takes every request
//! and never answers), alternating in one run. Also printed: when every
//! silent topic was settled (recorded without a definition after the
//! recorder's timeout, 5 s by default).
//!
//! ```text
//! cargo bench -p shm-bag --bench recorder_start
//! SHM_BAG_BENCH_ROUNDS=9 cargo bench -p shm-bag --bench recorder_start
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use shm_bag::{RecordOptions, Recorder, Selection, TypeDefinition};
use shm_cdr::msgs::std_msgs::msg::String as RosString;
use shm_cdr::msgs::type_description_interfaces::srv::GetTypeDescription;
use shm_runtime::rmw::Qos;
use shm_runtime::service::ServiceRequest;
use shm_runtime::{testing, RosNode};
use zenoh::Wait;

const SILENT_TOPICS: usize = 50;
const LIMIT: Duration = Duration::from_secs(60);

/// One round: seconds to the first `/chatter` message written, and to every
/// channel settled.
fn round(silent_topics: usize, index: usize) -> Option<(f64, f64)> {
    let port = testing::free_port().ok()?;
    let open = |listen| {
        zenoh::open(testing::peer_config(port, listen).ok()?)
            .wait()
            .ok()
    };
    let a = open(true)?;
    let b = open(false)?;
    let silent = RosNode::builder(&a, "silent")
        .domain_id(0)
        .type_description_service(false)
        .wait()
        .ok()?;
    let unanswered: Arc<Mutex<Vec<ServiceRequest<GetTypeDescription>>>> = Arc::default();
    let kept = unanswered.clone();
    let _never = silent
        .declare_service::<GetTypeDescription>("~/get_type_description")
        .callback(move |request| kept.lock().unwrap_or_else(|e| e.into_inner()).push(request))
        .wait()
        .ok()?;
    let _silent_publishers: Vec<_> = (0..silent_topics)
        .filter_map(|i| {
            silent
                .declare_serialized_publisher(
                    &format!("/silent/t{i}"),
                    &format!("silent_msgs/msg/T{i}"),
                    &format!("RIHS01_{i:064x}"),
                    Qos::default(),
                )
                .wait()
                .ok()
        })
        .collect();
    let talker = RosNode::builder(&a, "talker").domain_id(0).wait().ok()?;
    let chatter = talker
        .declare_publisher::<RosString>("/chatter")
        .wait()
        .ok()?;
    let running = AtomicBool::new(true);
    let dir = std::env::temp_dir().join(format!(
        "shm_bag_start_bench_{}_{index}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let result = std::thread::scope(|scope| {
        scope.spawn(|| {
            while running.load(Ordering::Relaxed) {
                let _ = chatter
                    .publish(&RosString {
                        data: "tick".into(),
                    })
                    .wait();
                std::thread::sleep(Duration::from_millis(1));
            }
        });
        let selection = Selection {
            all: true,
            exclude: regex::Regex::new("^/parameter_events$").ok(),
            ..Selection::default()
        };
        let mut options = RecordOptions::new(dir.join("bag"), selection);
        options.domain_id = Some(0);
        let start = Instant::now();
        let recorder = Recorder::start(&b, options).ok()?;
        let mut first = None;
        let mut settled = None;
        while start.elapsed() < LIMIT && (first.is_none() || settled.is_none()) {
            let stats = recorder.stats();
            if first.is_none()
                && stats
                    .channels
                    .iter()
                    .any(|c| c.topic == "/chatter" && c.written > 0)
            {
                first = Some(start.elapsed().as_secs_f64());
            }
            if settled.is_none()
                && stats.channels.len() > silent_topics
                && stats
                    .channels
                    .iter()
                    .all(|c| c.definition != TypeDefinition::Learning)
            {
                settled = Some(start.elapsed().as_secs_f64());
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        running.store(false, Ordering::Relaxed);
        let _ = recorder.stop();
        Some((first?, settled?))
    });
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() {
    let rounds: usize = std::env::var("SHM_BAG_BENCH_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    let mut times: [(Vec<f64>, Vec<f64>); 2] = Default::default();
    let mut failed = [0usize; 2];
    for r in 0..rounds {
        for (k, silent) in [0, SILENT_TOPICS].into_iter().enumerate() {
            match round(silent, r * 2 + k) {
                Some((first, settled)) => {
                    times[k].0.push(first);
                    times[k].1.push(settled);
                }
                None => failed[k] += 1,
            }
        }
    }
    println!("| silent topics present | first /chatter message written (median) | every topic settled (median) | rounds | failed |");
    println!("|---|---|---|---|---|");
    for (k, silent) in [0, SILENT_TOPICS].into_iter().enumerate() {
        let (first, settled) = &mut times[k];
        println!(
            "| {silent} | {:.0} ms | {:.0} ms | {} | {} |",
            median(first) * 1e3,
            median(settled) * 1e3,
            first.len(),
            failed[k]
        );
    }
    if failed.iter().any(|&f| f > 0) {
        std::process::exit(1);
    }
}
