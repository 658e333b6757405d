//! Publish → subscriber-holding-the-decoded-message latency of PointCloud2 over
//! TCP loopback between two peer sessions in this process, one message in flight.
//!
//! (a) ours, user-managed SHM data field (zero-copy splice) + borrowed decode
//! (b) ours, automatic threshold (Vec data serialized into SHM) + borrowed decode
//! (c) what a user would otherwise write: `to_vec` + `put` with Zenoh's defaults,
//!     owned decode on receive
//! (d) SHM disabled in both sessions: our publisher on the heap, borrowed decode
//! (e) the floor: a pre-filled `ZShmMut` of the same size put and received, no
//!     decode
//! (f) ours, a loan: the cloud built in place (typed points written into the
//!     chunk) before the clock, then published as it lies + borrowed decode
//! (g) (a) with a fresh data buffer allocated and filled per message before the
//!     clock, as applications do (a) re-sends one buffer)
//!
//! (e), (f) and (g) allocate and fill before the clock, so they compare what
//! publishing a ready message costs.
//!
//! The patterns take turns in a fresh random order every round, each timing one
//! message right after an untimed one of its own (see [`measure_size`]).
//!
//! `cargo bench -p shm-cdr-examples --bench latency` prints a table of medians and
//! p90s, and writes `latency.svg` (latency vs size) next to this file's crate.

use std::time::{Duration, Instant};

use shm_cdr::msgs::sensor_msgs::{PointCloud2, PointCloud2Ref, PointField};
use shm_cdr::msgs::std_msgs::Header;
use shm_runtime::msgs::sensor_msgs::PointCloud2Shm;
use shm_runtime::ShmOptions;
use shm_runtime::{SessionExt, ShmBytes, ShmConfig, ShmContext};
use zenoh::{Config, Session, Wait};

const SIZES: [(usize, &str); 3] = [(64 << 10, "64 KiB"), (1 << 20, "1 MiB"), (8 << 20, "8 MiB")];
const TIMEOUT: Duration = Duration::from_secs(10);

fn sessions(port: u16, shm: bool) -> (Session, Session) {
    let config = |key: &str| {
        let mut c = Config::default();
        c.insert_json5("mode", "\"peer\"").unwrap();
        c.insert_json5("scouting/multicast/enabled", "false")
            .unwrap();
        c.insert_json5(
            "transport/shared_memory/enabled",
            if shm { "true" } else { "false" },
        )
        .unwrap();
        c.insert_json5(key, &format!("[\"tcp/127.0.0.1:{port}\"]"))
            .unwrap();
        c
    };
    let a = zenoh::open(config("listen/endpoints")).wait().unwrap();
    let b = zenoh::open(config("connect/endpoints")).wait().unwrap();
    (a, b)
}

fn cloud_fields(bytes: usize) -> (Header, u32, Vec<PointField>) {
    let header = Header {
        frame_id: "lidar".into(),
        ..Default::default()
    };
    (header, (bytes / 16) as u32, shm_cdr_examples::xyzi_fields())
}

fn vec_cloud(bytes: usize) -> PointCloud2 {
    let (header, width, fields) = cloud_fields(bytes);
    PointCloud2 {
        header,
        height: 1,
        width,
        fields,
        is_bigendian: false,
        point_step: 16,
        row_step: width * 16,
        data: (0..bytes).map(|i| (i % 251) as u8).collect(),
        is_dense: true,
    }
}

fn shm_cloud(bytes: usize, data: ShmBytes) -> PointCloud2Shm {
    let (header, width, fields) = cloud_fields(bytes);
    PointCloud2Shm {
        header,
        height: 1,
        width,
        fields,
        is_bigendian: false,
        point_step: 16,
        row_step: width * 16,
        data,
        is_dense: true,
    }
}

fn rounds(bytes: usize) -> usize {
    if bytes >= 8 << 20 {
        150
    } else {
        300
    }
}

/// memcpy of `bytes`, median µs, as the reference for (b)'s goal.
fn memcpy_us(bytes: usize) -> f64 {
    let src = vec![1u8; bytes];
    let mut dst = vec![0u8; bytes];
    let mut samples: Vec<Duration> = (0..200)
        .map(|_| {
            let t = Instant::now();
            dst.copy_from_slice(std::hint::black_box(&src));
            std::hint::black_box(&dst);
            t.elapsed()
        })
        .collect();
    samples.sort();
    samples[100].as_secs_f64() * 1e6
}

struct Row {
    label: &'static str,
    results: Vec<(f64, f64)>,
}

/// Median and p90 of `samples`, in µs.
fn stats(mut samples: Vec<Duration>) -> (f64, f64) {
    samples.sort();
    let at = |q: f64| samples[((samples.len() - 1) as f64 * q) as usize].as_secs_f64() * 1e6;
    (at(0.5), at(0.9))
}

/// One size: all patterns are interleaved round by round, in a fresh order each
/// round, so that drift in Zenoh's delivery latency hits them alike; (d) needs
/// sessions with SHM disabled, so it runs on its own pair.
fn measure_size(bytes: usize, port: u16) -> [(f64, f64); 8] {
    let (a, b) = sessions(port, true);
    let (a_noshm, b_noshm) = sessions(port + 1, false);
    let shm = ShmContext::new(ShmConfig::enabled().pool_size(64 << 20)).unwrap();

    let pub_a = a
        .declare_ros_publisher::<PointCloud2Shm>("bench/a")
        .shm(&shm)
        .wait()
        .unwrap();
    let sub_a = b
        .declare_ros_subscriber::<PointCloud2>("bench/a")
        .wait()
        .unwrap();
    let pub_b = a
        .declare_ros_publisher::<PointCloud2>("bench/b")
        .shm(&shm)
        .wait()
        .unwrap();
    let sub_b = b
        .declare_ros_subscriber::<PointCloud2>("bench/b")
        .wait()
        .unwrap();
    let pub_c = a.declare_publisher("bench/c").wait().unwrap();
    let sub_c = b.declare_subscriber("bench/c").wait().unwrap();
    let pub_d = a_noshm
        .declare_ros_publisher::<PointCloud2>("bench/d")
        .wait()
        .unwrap();
    let sub_d = b_noshm
        .declare_ros_subscriber::<PointCloud2>("bench/d")
        .wait()
        .unwrap();
    let pub_e = a.declare_publisher("bench/e").wait().unwrap();
    let sub_e = b.declare_subscriber("bench/e").wait().unwrap();
    for p in [&pub_c, &pub_e] {
        wait_matching(p);
    }
    assert!(pub_a.wait_for_subscribers(TIMEOUT) && pub_b.wait_for_subscribers(TIMEOUT));
    assert!(pub_d.wait_for_subscribers(TIMEOUT));

    let mut block = shm.alloc(bytes).unwrap();
    block.fill(3);
    let msg_a = shm_cloud(bytes, ShmBytes::from(block));
    let msg = vec_cloud(bytes);

    let mut scratch = vec![0u8; bytes];
    let (header, width, fields) = cloud_fields(bytes);
    let mut lens = shm_cdr::loan::InPlace::lens(&vec_cloud(0));
    lens.header = shm_cdr::loan::InPlace::lens(&header);
    lens.fields = shm_cdr::loan::InPlace::lens(&fields);
    lens.data = bytes;
    // One closure per measurement, in the order of the table's rows (the memcpy
    // reference at index 5); each returns the time of one message.
    let mut measurements: [Box<dyn FnMut() -> Duration + '_>; 8] = [
        // (a)
        Box::new(|| ros_round(&pub_a, &sub_a, &msg_a)),
        // (b)
        Box::new(|| ros_round(&pub_b, &sub_b, &msg)),
        // (c)
        Box::new(|| {
            let t = Instant::now();
            pub_c.put(shm_cdr::to_vec(&msg).unwrap()).wait().unwrap();
            let sample = sub_c.recv_timeout(TIMEOUT).unwrap().unwrap();
            let cloud: PointCloud2 = shm_cdr::from_bytes(&sample.payload().to_bytes()).unwrap();
            std::hint::black_box(cloud.data.len());
            t.elapsed()
        }),
        // (d)
        Box::new(|| ros_round(&pub_d, &sub_d, &msg)),
        // (e): the buffer is allocated and filled before the clock starts.
        Box::new(|| {
            let mut block = shm.alloc(bytes).unwrap();
            block.fill(5);
            let t = Instant::now();
            pub_e.put(block).wait().unwrap();
            let sample = sub_e.recv_timeout(TIMEOUT).unwrap().unwrap();
            std::hint::black_box(sample.payload().len());
            t.elapsed()
        }),
        // The memcpy reference for (b)'s copy, in the same cache conditions: after
        // its lead-in, the source was just read and the destination just written,
        // as (b)'s source and pool chunk were by the (b) before it.
        Box::new(|| {
            let t = Instant::now();
            scratch.copy_from_slice(std::hint::black_box(&msg.data));
            std::hint::black_box(&scratch);
            t.elapsed()
        }),
        // (f): the loan is taken and written before the clock starts.
        Box::new(|| {
            let mut loan = pub_b.loan(lens.clone()).unwrap();
            let cloud = loan.fields().unwrap();
            cloud.header.frame_id.write(&header.frame_id).unwrap();
            *cloud.height = 1;
            *cloud.width = width;
            *cloud.point_step = 16;
            *cloud.row_step = width * 16;
            cloud.is_dense.set(true);
            cloud.fields.write_slice(&fields).unwrap();
            let points = cloud.data.cast::<[f32; 4]>().unwrap();
            points.write_with(|i| [i as f32, 0.5, -1.0, 7.0]);
            let t = Instant::now();
            loan.publish().wait().unwrap();
            let sample = sub_b.recv_timeout(TIMEOUT).unwrap().unwrap();
            let cloud: PointCloud2Ref = sample.decode().unwrap();
            std::hint::black_box(cloud.data.len());
            t.elapsed()
        }),
        // (g): a fresh SHM data buffer per message, filled before the clock.
        Box::new(|| {
            let mut block = shm.alloc(bytes).unwrap();
            block.fill(7);
            let fresh = shm_cloud(bytes, ShmBytes::from(block));
            ros_round(&pub_a, &sub_a, &fresh)
        }),
    ];
    let mut samples: [Vec<Duration>; 8] = Default::default();
    let mut order: Vec<usize> = (0..measurements.len()).collect();
    // Seeded: a rerun measures in the same orders.
    let mut rng = fastrand::Rng::with_seed(0x5eed);
    for round in 0..rounds(bytes) + 10 {
        // The first rounds warm up.
        let keep = round >= 10;
        // A fresh order every round, so drift hits every pattern alike; and an
        // untimed lead-in before each timed message, so that it follows one of
        // its own kind (what another pattern leaves in the caches and the pool
        // is not this one's cost).
        rng.shuffle(&mut order);
        for &i in &order {
            measurements[i]();
            let took = measurements[i]();
            if keep {
                samples[i].push(took);
            }
        }
    }
    samples.map(stats)
}

fn main() {
    let labels = [
        "(a) ours, SHM field spliced + borrowed decode",
        "(b) ours, threshold → SHM + borrowed decode",
        "(c) to_vec + put (Zenoh defaults), owned decode",
        "(d) SHM disabled, heap + borrowed decode",
        "(e) floor: pre-filled ZShmMut put, no decode",
        "(f) ours, loan: built in place + borrowed decode",
        "(g) (a) with a fresh SHM buffer per message",
    ];
    let mut rows: Vec<Row> = labels
        .iter()
        .map(|label| Row {
            label,
            results: Vec::new(),
        })
        .collect();
    let mut copies = Vec::new();
    for (i, (bytes, _)) in SIZES.iter().enumerate() {
        let results = measure_size(*bytes, 27450 + 2 * i as u16);
        // Index 5 is the memcpy reference, not a row.
        let measured = results[..5].iter().chain(&results[6..]);
        for (row, result) in rows.iter_mut().zip(measured) {
            row.results.push(*result);
        }
        copies.push(results[5].0);
    }
    print_table(&rows, &copies);
    plot(&rows);
}

/// Publish `msg` with our publisher and decode it borrowed at the subscriber:
/// the time from the publish call to holding the decoded message.
fn ros_round<T: shm_cdr::RosMessage>(
    publisher: &shm_runtime::RosPublisher<T>,
    subscriber: &shm_runtime::RosSubscriber<PointCloud2>,
    msg: &T,
) -> Duration {
    let t = Instant::now();
    publisher.publish(msg).wait().unwrap();
    let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
    let cloud: PointCloud2Ref = sample.decode().unwrap();
    std::hint::black_box(cloud.data.len());
    t.elapsed()
}

fn wait_matching(publisher: &zenoh::pubsub::Publisher<'_>) {
    let deadline = Instant::now() + TIMEOUT;
    while !publisher
        .matching_status()
        .wait()
        .is_ok_and(|s| s.matching())
    {
        assert!(Instant::now() < deadline, "no subscriber matched");
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn print_table(rows: &[Row], copies: &[f64]) {
    print!("| pattern |");
    for (_, name) in SIZES {
        print!(" {name} median | {name} p90 |");
    }
    println!();
    println!("|---|{}", "---:|".repeat(2 * SIZES.len()));
    for row in rows {
        print!("| {} |", row.label);
        for (median, p90) in &row.results {
            print!(" {median:.0} µs | {p90:.0} µs |");
        }
        println!();
    }
    let floor = &rows[4].results;
    let (a, b, c) = (&rows[0].results, &rows[1].results, &rows[2].results);
    let (f, g) = (&rows[5].results, &rows[6].results);
    for (i, (bytes, name)) in SIZES.iter().enumerate() {
        let hot = memcpy_us(*bytes);
        let over = b[i].0 - floor[i].0;
        let budget = 1.2 * copies[i];
        println!(
            "{name}: (a)/(e) = {:.2}×; (b) − (e) = {over:+.0} µs vs 1.2× memcpy = {budget:.0} µs [{}] (memcpy in the loop {:.0} µs, hot {hot:.0} µs); (c)/(b) = {:.2}×",
            a[i].0 / floor[i].0,
            if over <= budget { "within" } else { "OVER" },
            copies[i],
            c[i].0 / b[i].0
        );
        println!(
            "{name}: loan (f)/(e) = {:.2}×, (b)/(f) = {:.2}×; fresh splice (g)/(e) = {:.2}×",
            f[i].0 / floor[i].0,
            b[i].0 / f[i].0,
            g[i].0 / floor[i].0
        );
    }
}

fn plot(rows: &[Row]) {
    use plotters::prelude::*;
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/latency.svg");
    let root = SVGBackend::new(path, (760, 440)).into_drawing_area();
    let _ = root.fill(&WHITE);
    let max = rows
        .iter()
        .flat_map(|r| r.results.iter().map(|x| x.0))
        .fold(1.0, f64::max);
    let sizes: Vec<f64> = SIZES.iter().map(|(b, _)| *b as f64 / 1024.0).collect();
    let Ok(mut chart) = ChartBuilder::on(&root)
        .caption(
            "PointCloud2 publish → decoded, median (µs), log-log",
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d((48.0..12_000.0).log_scale(), (10.0..max * 1.5).log_scale())
    else {
        return;
    };
    let _ = chart
        .configure_mesh()
        .x_desc("message size (KiB)")
        .y_desc("latency (µs)")
        .draw();
    let colors = [RED, BLUE, MAGENTA, GREEN, BLACK, CYAN, YELLOW];
    for (row, color) in rows.iter().zip(colors) {
        let points: Vec<(f64, f64)> = sizes
            .iter()
            .zip(&row.results)
            .map(|(s, r)| (*s, r.0))
            .collect();
        if let Ok(series) =
            chart.draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))
        {
            series
                .label(row.label)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], color));
        }
        let _ = chart.draw_series(points.iter().map(|p| Circle::new(*p, 3, color.filled())));
    }
    let _ = chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw();
    let _ = root.present();
    println!("plot written to {path}");
}
