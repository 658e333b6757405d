//! shm-cdr next to hiroz-cdr, cdr, cdr-encoding, Fast-CDR and memcpy, on the
//! same messages and values, in one run.
//!
//! `cargo bench -p shm-cdr-peer-bench` (Fast-CDR needs `ros-fastcdr` in a venv,
//! see `build.rs`). Before timing anything it checks bytes (a peer that writes
//! or reads a message differently from us is reported, not timed, on it). After
//! the run it writes `peer-bench/RESULTS.md` (medians, GB/s, ratios) and
//! `peer-bench/peers.svg` (bar chart) from criterion's estimates.

use std::collections::BTreeMap;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput};
use shm_cdr::{encode_into, encoded_size, from_bytes, from_bytes_into, to_vec};
use shm_cdr_peer_bench::check::{self, Verdict, CDR, CDR_ENCODING, FAST_CDR, HIROZ};
use shm_cdr_peer_bench::messages::{StringList, StringListCompact};
use shm_cdr_peer_bench::peers::{cdr_crate, cdr_encoding, hiroz};
use shm_cdr_peer_bench::{samples, Message, Sample};

const OURS: &str = "shm-cdr";
const MEMCPY: &str = "memcpy";
/// Libraries in table order.
const LIBRARIES: [&str; 6] = [MEMCPY, OURS, HIROZ, CDR, CDR_ENCODING, FAST_CDR];
/// Operations in table order.
const OPS: [&str; 7] = [
    "encode",
    "to_vec",
    "size",
    "decode",
    "decode_compact",
    "decode_into",
    "decode_borrowed",
];

fn output_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/criterion-peers")
}

fn agrees(verdicts: &[Verdict], library: &str, message: &str) -> bool {
    verdicts
        .iter()
        .any(|v| v.library == library && v.message == message && v.agrees())
}

fn bench_message<M: Message>(c: &mut Criterion, sample: &Sample<M>, verdicts: &[Verdict]) {
    let msg = &sample.msg;
    let name = sample.name;
    let bytes = to_vec(msg).expect("sample encodes");
    let size = bytes.len();
    let mirror = msg.mirror();

    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Bytes(size as u64));
    if size > 1 << 20 {
        group.sample_size(20);
    }

    let mut dst = vec![0u8; size];
    group.bench_function(BenchmarkId::new("encode", MEMCPY), |b| {
        b.iter(|| dst.copy_from_slice(black_box(&bytes)))
    });

    // shm-cdr
    group.bench_function(BenchmarkId::new("encode", OURS), |b| {
        b.iter(|| encode_into(black_box(msg), &mut dst).expect("fits"))
    });
    group.bench_function(BenchmarkId::new("to_vec", OURS), |b| {
        b.iter(|| to_vec(black_box(msg)).expect("encodes"))
    });
    group.bench_function(BenchmarkId::new("size", OURS), |b| {
        b.iter(|| encoded_size(black_box(msg)))
    });
    group.bench_function(BenchmarkId::new("decode", OURS), |b| {
        b.iter(|| from_bytes::<M>(black_box(&bytes)).expect("decodes"))
    });
    // Into a value kept from the previous message, as Fast-CDR decodes into its
    // existing object: strings and vectors keep their memory.
    let mut kept: M = from_bytes(&bytes).expect("decodes");
    group.bench_function(BenchmarkId::new("decode_into", OURS), |b| {
        b.iter(|| from_bytes_into(black_box(&bytes), &mut kept).expect("decodes"))
    });
    group.bench_function(BenchmarkId::new("decode_borrowed", OURS), |b| {
        b.iter(|| from_bytes::<M::Ref<'_>>(black_box(&bytes)).expect("decodes"))
    });

    let mut reuse = Vec::with_capacity(size);
    if agrees(verdicts, HIROZ, name) {
        group.bench_function(BenchmarkId::new("encode", HIROZ), |b| {
            b.iter(|| hiroz::encode_reuse(black_box(&mirror), &mut reuse))
        });
        group.bench_function(BenchmarkId::new("to_vec", HIROZ), |b| {
            b.iter(|| hiroz::to_vec(black_box(&mirror)))
        });
        group.bench_function(BenchmarkId::new("size", HIROZ), |b| {
            b.iter(|| hiroz::size(black_box(&mirror)))
        });
        group.bench_function(BenchmarkId::new("decode", HIROZ), |b| {
            b.iter(|| hiroz::decode::<M::Mirror>(black_box(&bytes)).expect("decodes"))
        });
    }
    if agrees(verdicts, CDR, name) {
        group.bench_function(BenchmarkId::new("encode", CDR), |b| {
            b.iter(|| cdr_crate::encode_reuse(black_box(&mirror), &mut reuse).expect("encodes"))
        });
        group.bench_function(BenchmarkId::new("to_vec", CDR), |b| {
            b.iter(|| cdr_crate::to_vec(black_box(&mirror)).expect("encodes"))
        });
        group.bench_function(BenchmarkId::new("size", CDR), |b| {
            b.iter(|| cdr_crate::size(black_box(&mirror)))
        });
        group.bench_function(BenchmarkId::new("decode", CDR), |b| {
            b.iter(|| cdr_crate::decode::<M::Mirror>(black_box(&bytes)).expect("decodes"))
        });
    }
    if agrees(verdicts, CDR_ENCODING, name) {
        group.bench_function(BenchmarkId::new("encode", CDR_ENCODING), |b| {
            b.iter(|| cdr_encoding::encode_reuse(black_box(&mirror), &mut reuse).expect("encodes"))
        });
        group.bench_function(BenchmarkId::new("to_vec", CDR_ENCODING), |b| {
            b.iter(|| cdr_encoding::to_vec(black_box(&mirror)).expect("encodes"))
        });
        group.bench_function(BenchmarkId::new("decode", CDR_ENCODING), |b| {
            b.iter(|| cdr_encoding::decode::<M::Mirror>(black_box(&bytes)).expect("decodes"))
        });
    }
    #[cfg(fastcdr)]
    if agrees(verdicts, FAST_CDR, name) {
        use shm_cdr_peer_bench::fastcdr::FastMsg;
        let fast = FastMsg::load(M::fast_cdr(), &bytes).expect("checked");
        let mut target = FastMsg::load(M::fast_cdr(), &bytes).expect("checked");
        group.bench_function(BenchmarkId::new("encode", FAST_CDR), |b| {
            b.iter(|| fast.encode(black_box(&mut dst)).expect("fits"))
        });
        group.bench_function(BenchmarkId::new("size", FAST_CDR), |b| {
            b.iter(|| black_box(&fast).size())
        });
        // A new object each message, as an rclcpp subscription takes one.
        group.bench_function(BenchmarkId::new("decode", FAST_CDR), |b| {
            b.iter(|| FastMsg::load(M::fast_cdr(), black_box(&bytes)).expect("checked"))
        });
        // Into the object kept from the previous message.
        group.bench_function(BenchmarkId::new("decode_into", FAST_CDR), |b| {
            b.iter(|| assert!(target.decode(black_box(&bytes))))
        });
    }
    group.finish();
}

/// The owned decode of a message whose strings are `CompactString`s (up to 24
/// bytes held inline), beside the same message's other rows.
fn bench_compact(c: &mut Criterion, sample: &Sample<StringList>) {
    let bytes = to_vec(&sample.msg).expect("sample encodes");
    let compact: StringListCompact = from_bytes(&bytes).expect("decodes");
    assert_eq!(to_vec(&compact).expect("encodes"), bytes);
    let mut group = c.benchmark_group(sample.name);
    group.throughput(Throughput::Bytes(bytes.len() as u64));
    group.bench_function(BenchmarkId::new("decode_compact", OURS), |b| {
        b.iter(|| from_bytes::<StringListCompact>(black_box(&bytes)).expect("decodes"))
    });
    group.finish();
}

/// One measured median.
struct Median {
    ns: f64,
    bytes: u64,
}

/// Read every `new/estimates.json` median under criterion's output directory,
/// keyed by (message, operation, library).
fn read_medians(root: &Path) -> BTreeMap<(String, String, String), Median> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.ends_with("new/benchmark.json") {
                let read = |p: &Path| -> Option<serde_json::Value> {
                    serde_json::from_str(&std::fs::read_to_string(p).ok()?).ok()
                };
                let (Some(meta), Some(est)) =
                    (read(&path), read(&path.with_file_name("estimates.json")))
                else {
                    continue;
                };
                let text = |v: &serde_json::Value| v.as_str().unwrap_or_default().to_string();
                let key = (
                    text(&meta["group_id"]),
                    text(&meta["function_id"]),
                    text(&meta["value_str"]),
                );
                let ns = est["median"]["point_estimate"].as_f64().unwrap_or(f64::NAN);
                let bytes = meta["throughput"]["Bytes"].as_u64().unwrap_or(0);
                out.insert(key, Median { ns, bytes });
            }
        }
    }
    out
}

fn fmt_ns(ns: f64) -> String {
    if ns >= 1e6 {
        format!("{:.2} ms", ns / 1e6)
    } else if ns >= 1e3 {
        format!("{:.1} µs", ns / 1e3)
    } else {
        format!("{ns:.0} ns")
    }
}

/// A median, with the message's bytes per second for operations that move every
/// byte (a size computation or a borrowed decode does not).
fn fmt_cell(m: &Median, op: &str) -> String {
    match op {
        "encode" | "to_vec" | "decode" | "decode_compact" | "decode_into" => {
            format!("{} ({:.1} GB/s)", fmt_ns(m.ns), m.bytes as f64 / m.ns)
        }
        _ => fmt_ns(m.ns),
    }
}

/// The markdown report: one row per (message, operation), one column per
/// library, and our time over the fastest peer's (below 1 = we are faster).
/// Borrowed decode and decode into a kept value are compared with the peers' decode.
fn write_report(
    messages: &[&str],
    verdicts: &[Verdict],
) -> BTreeMap<(String, String, String), Median> {
    let medians = read_medians(&output_dir());
    let mut md = String::from(
        "<!-- generated by `cargo bench -p shm-cdr-peer-bench`; medians of criterion samples -->\n",
    );
    md.push_str("| message | op | ");
    md.push_str(&LIBRARIES.join(" | "));
    md.push_str(" | shm-cdr ÷ fastest peer |\n|---|---|");
    md.push_str(&"---:|".repeat(LIBRARIES.len() + 1));
    md.push('\n');
    for message in messages {
        for op in OPS {
            let get = |lib: &str, op: &str| {
                medians.get(&(message.to_string(), op.to_string(), lib.to_string()))
            };
            if get(OURS, op).is_none() {
                continue;
            }
            // A borrowed decode, or one into strings held inline, stands
            // against the peers' decode; a decode into a kept value against
            // Fast-CDR's into its kept object.
            let peer_op = match op {
                "decode_borrowed" | "decode_compact" => "decode",
                _ => op,
            };
            let mut row = format!("| {message} | {op} |");
            for lib in LIBRARIES {
                let cell = match lib {
                    MEMCPY | OURS => get(lib, if lib == MEMCPY { "encode" } else { op }),
                    _ if op == "decode_borrowed" || op == "decode_compact" => None,
                    _ => get(lib, op),
                };
                let text = match cell {
                    // A memcpy of the message's bytes is the reference for every
                    // operation that moves them, not for computing a size.
                    Some(_) if lib == MEMCPY && op == "size" => String::new(),
                    Some(m) => fmt_cell(m, if lib == MEMCPY { "encode" } else { op }),
                    None if lib == MEMCPY
                        || lib == OURS
                        || op == "decode_borrowed"
                        || op == "decode_compact"
                        || op == "decode_into" =>
                    {
                        "–".into()
                    }
                    None if verdicts
                        .iter()
                        .any(|v| v.library == lib && v.message == *message) =>
                    {
                        if agrees(verdicts, lib, message) {
                            "–".into() // the library has no such operation
                        } else {
                            "wrong bytes".into()
                        }
                    }
                    None => "not built".into(),
                };
                row.push_str(&format!(" {text} |"));
            }
            let fastest_peer = [HIROZ, CDR, CDR_ENCODING, FAST_CDR]
                .into_iter()
                .filter_map(|lib| get(lib, peer_op).map(|m| (lib, m.ns)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match (get(OURS, op), fastest_peer) {
                (Some(ours), Some((lib, ns))) => {
                    row.push_str(&format!(" {:.2} ({lib}) |", ours.ns / ns))
                }
                _ => row.push_str(" – |"),
            }
            md.push_str(&row);
            md.push('\n');
        }
    }
    md.push_str(
        "\nByte checks before timing (a library is timed on a message only if it agrees):\n\n",
    );
    for v in verdicts.iter().filter(|v| !v.agrees()) {
        md.push_str(&format!(
            "- {} on {}: {}\n",
            v.library,
            v.message,
            v.problems.join("; ")
        ));
    }
    let agreeing = verdicts.iter().filter(|v| v.agrees()).count();
    md.push_str(&format!(
        "- {agreeing} of {} (library, message) pairs wrote and read exactly shm-cdr's bytes.\n",
        verdicts.len()
    ));
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("RESULTS.md");
    match std::fs::write(&path, &md) {
        Ok(()) => println!("wrote {}", path.display()),
        Err(e) => eprintln!("could not write {}: {e}", path.display()),
    }
    print!("{md}");
    medians
}

/// Bars of encode and decode medians per message and library, log scale.
fn write_chart(
    messages: &[&str],
    medians: &BTreeMap<(String, String, String), Median>,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("peers.svg");
    let root = SVGBackend::new(&path, (1100, 760)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((2, 1));
    let libs = [OURS, HIROZ, CDR, CDR_ENCODING, FAST_CDR, MEMCPY];
    let colors = [
        RGBColor(214, 39, 40),
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(127, 127, 127),
    ];
    for (panel, op) in panels.iter().zip(["encode", "decode"]) {
        let value = |message: &str, lib: &str| {
            let op = match (op, lib) {
                ("decode", OURS) => "decode_borrowed",
                (_, MEMCPY) => "encode",
                _ => op,
            };
            medians
                .get(&(message.to_string(), op.to_string(), lib.to_string()))
                .map(|m| m.ns)
        };
        let all: Vec<f64> = messages
            .iter()
            .flat_map(|m| libs.iter().filter_map(move |l| value(m, l)))
            .collect();
        let lo = all.iter().cloned().fold(f64::INFINITY, f64::min).max(1.0) / 2.0;
        let hi = all.iter().cloned().fold(0.0, f64::max) * 2.0;
        let title = if op == "encode" {
            "encode (into a pre-sized / reused buffer), ns per message, log scale"
        } else {
            "decode (shm-cdr: borrowed; peers: owned; Fast-CDR: into a reused object)"
        };
        let mut chart = ChartBuilder::on(panel)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..messages.len() as f64, (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(messages.len() * 2 + 1)
            .x_label_formatter(&|x| {
                let i = (*x - 0.5).round();
                if (x - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
                    messages
                        .get(i as usize)
                        .map(|s| s.to_string())
                        .unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|y| fmt_ns(*y))
            .draw()?;
        let width = 0.8 / libs.len() as f64;
        for (li, (lib, color)) in libs.iter().zip(colors).enumerate() {
            let bars: Vec<_> = messages
                .iter()
                .enumerate()
                .filter_map(|(mi, m)| {
                    let x0 = mi as f64 + 0.1 + li as f64 * width;
                    value(m, lib).map(|ns| {
                        Rectangle::new([(x0, lo), (x0 + width * 0.9, ns)], color.filled())
                    })
                })
                .collect();
            chart.draw_series(bars)?.label(*lib).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 10, y + 5)], color.filled())
            });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    println!("wrote {}", path.display());
    Ok(())
}

fn main() {
    let verdicts = check::check_all();
    for v in verdicts.iter().filter(|v| !v.agrees()) {
        println!(
            "not timed: {} on {}: {}",
            v.library,
            v.message,
            v.problems.join("; ")
        );
    }
    if !cfg!(fastcdr) {
        println!("Fast-CDR skipped: not found at build time (see peer-bench/build.rs)");
    }

    let mut c = Criterion::default()
        .output_directory(&output_dir())
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_millis(1500))
        .configure_from_args();

    let header = samples::header_small();
    let clouds = samples::point_clouds();
    let image = samples::image_1080p();
    let joints = samples::joint_state();
    let poses = samples::pose_array();
    let strings = samples::string_list();
    let stamped = samples::stamped_values();
    bench_message(&mut c, &header, &verdicts);
    for cloud in &clouds {
        bench_message(&mut c, cloud, &verdicts);
    }
    bench_message(&mut c, &image, &verdicts);
    bench_message(&mut c, &joints, &verdicts);
    bench_message(&mut c, &poses, &verdicts);
    bench_message(&mut c, &strings, &verdicts);
    bench_compact(&mut c, &strings);
    bench_message(&mut c, &stamped, &verdicts);
    c.final_summary();

    let messages = [
        header.name,
        clouds[0].name,
        clouds[1].name,
        image.name,
        joints.name,
        poses.name,
        strings.name,
        stamped.name,
    ];
    let medians = write_report(&messages, &verdicts);
    if let Err(e) = write_chart(&messages, &medians) {
        eprintln!("chart not written: {e}");
    }
}
