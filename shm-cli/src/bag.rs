//! `shm-ros2 bag …`: record, play and describe recordings as ros2bag does,
//! through shm-bag (MCAP as rosbag2 writes it).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use clap::{Args, Subcommand, ValueEnum};
use shm_bag::{
    Bag, BagMetadata, ClockTrigger, Compression, ConvertOptions, PlayOptions, Player,
    RecordOptions, Recorder, Selection, WriteOptions,
};

use shm_cdr::msgs::service_msgs::msg::ServiceEventInfo;

use crate::context::Context;
use crate::{counted, Error};

#[derive(Debug, Subcommand)]
pub(crate) enum BagCommand {
    /// Record ROS data to a bag (MCAP, as rosbag2 writes it).
    Record(RecordArgs),
    /// Play back ROS data from a bag.
    Play(PlayArgs),
    /// Print information about a bag to the screen.
    Info {
        /// Bag to open: a bag directory, an MCAP or a sqlite3 (.db3) file.
        bag_path: PathBuf,
        /// Count each recorded service's requests and responses (reads
        /// every service event).
        #[arg(short = 'v', long)]
        verbose: bool,
    },
    /// Convert bags (MCAP or sqlite3; several are merged in time order) into
    /// one MCAP bag, with the chunk compression and splitting given.
    Convert(ConvertArgs),
    /// Make a bag whose recording did not finish (killed, power cut, disk
    /// full) readable again: rewrite its unfinished files from their complete
    /// records (the originals kept as `<name>.unfinished`) and its
    /// metadata.yaml from the files.
    Reindex {
        /// The bag directory.
        bag_path: PathBuf,
    },
}

/// rosbag2's MCAP storage presets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Preset {
    /// Chunked, uncompressed (the default).
    None,
    /// Chunked, uncompressed: already the fastest.
    Fastwrite,
    /// Chunks compressed with Zstandard, fastest level.
    ZstdFast,
    /// Chunks compressed with Zstandard, 4 MiB chunks.
    ZstdSmall,
}

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ChunkCompression {
    /// Zstandard.
    Zstd,
    /// LZ4.
    Lz4,
}

#[derive(Debug, Args)]
pub(crate) struct RecordArgs {
    /// List of topics to record.
    topics: Vec<String>,
    /// Record all topics (hidden ones only with --include-hidden-topics).
    #[arg(short = 'a', long = "all-topics")]
    all_topics: bool,
    /// Record the events of all services (their `_service_event` topics,
    /// published by services and clients with introspection on).
    #[arg(long)]
    all_services: bool,
    /// Record all topics and the events of all services.
    #[arg(long)]
    all: bool,
    /// Record the events of these services.
    #[arg(short = 'S', long, num_args = 1.., value_name = "SERVICE")]
    services: Vec<String>,
    /// Record only topics matching this regular expression.
    #[arg(short = 'e', long)]
    regex: Option<String>,
    /// Do not record topics matching this regular expression.
    #[arg(short = 'x', long = "exclude-regex", alias = "exclude")]
    exclude_regex: Option<String>,
    /// Record hidden topics too (a name part starting with `_`).
    #[arg(long)]
    include_hidden_topics: bool,
    /// Destination of the bag directory (default rosbag2_<date>-<time>).
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    #[command(flatten)]
    files: FileArgs,
    /// Bytes of received messages that may wait for the disk; past it
    /// messages are dropped and counted.
    #[arg(long, default_value_t = 512 * 1024 * 1024)]
    max_cache_size: usize,
    /// Stop after this many seconds (default: at Ctrl-C).
    #[arg(long)]
    duration: Option<f64>,
    /// Print no progress line.
    #[arg(long)]
    no_progress: bool,
    /// Start paused: nothing is written until resumed (space, or the
    /// recorder's ~/resume service).
    #[arg(long)]
    start_paused: bool,
    /// Do not read keys from the terminal (space: pause/resume).
    #[arg(long)]
    disable_keyboard_controls: bool,
    /// Keep the newest messages in memory (up to --max-cache-size) and write
    /// them only when the recorder's ~/snapshot service is called.
    #[arg(long)]
    snapshot_mode: bool,
}

/// How the files of a new bag are written.
#[derive(Debug, Args)]
pub(crate) struct FileArgs {
    /// Start a new file once one holds this many bytes (0: never).
    #[arg(short = 'b', long, default_value_t = 0)]
    max_bag_size: u64,
    /// Start a new file once one spans this many seconds (0: never).
    #[arg(short = 'd', long, default_value_t = 0)]
    max_bag_duration: u64,
    /// MCAP storage preset (rosbag2's names).
    #[arg(long, value_enum, default_value_t = Preset::None)]
    storage_preset_profile: Preset,
    /// Compress MCAP chunks (rosbag2 does this through the storage preset).
    #[arg(long, value_enum)]
    compression_format: Option<ChunkCompression>,
}

impl FileArgs {
    fn apply(&self, write: &mut WriteOptions) {
        write.max_bag_size = (self.max_bag_size > 0).then_some(self.max_bag_size);
        write.max_bag_duration =
            (self.max_bag_duration > 0).then(|| Duration::from_secs(self.max_bag_duration));
        match self.storage_preset_profile {
            Preset::None | Preset::Fastwrite => {}
            Preset::ZstdFast => write.compression = Some(Compression::Zstd),
            Preset::ZstdSmall => {
                write.compression = Some(Compression::Zstd);
                write.chunk_size = 4 * 1024 * 1024;
            }
        }
        if let Some(c) = self.compression_format {
            write.compression = Some(match c {
                ChunkCompression::Zstd => Compression::Zstd,
                ChunkCompression::Lz4 => Compression::Lz4,
            });
        }
    }
}

#[derive(Debug, Args)]
pub(crate) struct ConvertArgs {
    /// A bag to read: a bag directory, an MCAP or a sqlite3 (.db3) file.
    /// Given more than once, the bags are merged in time order.
    #[arg(short = 'i', long = "input", required = true, value_name = "BAG")]
    inputs: Vec<PathBuf>,
    /// The new bag directory (it must not exist).
    #[arg(short = 'o', long, value_name = "DIR")]
    output: PathBuf,
    /// Only these topics (default: all).
    #[arg(long, num_args = 1..)]
    topics: Vec<String>,
    /// Leave out topics matching this regular expression.
    #[arg(short = 'x', long = "exclude-regex")]
    exclude_regex: Option<String>,
    #[command(flatten)]
    files: FileArgs,
}

#[derive(Debug, Args)]
pub(crate) struct PlayArgs {
    /// Bag to open: a bag directory, an MCAP or a sqlite3 (.db3) file.
    bag_path: PathBuf,
    /// Print no progress line (it is printed only on a terminal).
    #[arg(long)]
    no_progress: bool,
    /// Rate at which to play back messages.
    #[arg(short = 'r', long, default_value_t = 1.0)]
    rate: f64,
    /// Play the bag in a loop, until Ctrl-C.
    #[arg(short = 'l', long = "loop")]
    loop_playback: bool,
    /// Topics to replay (default: all).
    #[arg(long, num_args = 1..)]
    topics: Vec<String>,
    /// Sleep this many seconds before playing.
    #[arg(short = 'd', long, default_value_t = 0.0)]
    delay: f64,
    /// Publish the playback's time on /clock this many times a second (40
    /// when given without a value), as a ROS time source; the recorded
    /// /clock is then not played.
    #[arg(long, value_name = "HZ", num_args = 0..=1, default_missing_value = "40",
          conflicts_with_all = ["clock_topics", "clock_topics_all"])]
    clock: Option<f64>,
    /// Publish the playback's time on /clock just before each message of
    /// these topics.
    #[arg(long, num_args = 1.., conflicts_with = "clock_topics_all")]
    clock_topics: Vec<String>,
    /// Publish the playback's time on /clock just before each message.
    #[arg(long)]
    clock_topics_all: bool,
    /// Start the playback this many seconds into the bag.
    #[arg(long, default_value_t = 0.0, value_name = "SECONDS")]
    start_offset: f64,
    /// Play this many seconds of the bag, from the start offset (negative:
    /// all of it).
    #[arg(long, default_value_t = -1.0, value_name = "SECONDS", allow_negative_numbers = true)]
    playback_duration: f64,
    /// Start the playback paused.
    #[arg(short = 'p', long)]
    start_paused: bool,
    /// Do not read keys from the terminal (space: pause/resume, right:
    /// next message, up/down: rate ±0.1).
    #[arg(long)]
    disable_keyboard_controls: bool,
}

pub(crate) fn run(context: Option<&Context>, command: BagCommand) -> Result<(), Error> {
    match command {
        BagCommand::Info { bag_path, verbose } => info(&bag_path, verbose),
        BagCommand::Reindex { bag_path } => reindex(&bag_path),
        BagCommand::Convert(args) => convert(&args),
        BagCommand::Record(args) => match context {
            Some(context) => record(context, args),
            None => Err("bag record needs a Zenoh session".into()),
        },
        BagCommand::Play(args) => match context {
            Some(context) => play(context, &args),
            None => Err("bag play needs a Zenoh session".into()),
        },
    }
}

fn convert(args: &ConvertArgs) -> Result<(), Error> {
    if args.output.is_file()
        && args
            .output
            .extension()
            .is_some_and(|e| e == "yaml" || e == "yml")
    {
        return Err(format!(
            "{}: -o takes the new bag directory here, not ros2 bag convert's output options \
             file: give the directory, and the options as flags (--compression-format, \
             --storage-preset-profile, -b, -d, --topics, -x)",
            args.output.display()
        )
        .into());
    }
    let inputs = args
        .inputs
        .iter()
        .map(|path| Bag::open(path))
        .collect::<Result<Vec<_>, _>>()?;
    let exclude = args
        .exclude_regex
        .as_deref()
        .map(regex::Regex::new)
        .transpose()
        .map_err(|e| format!("--exclude-regex: {e}"))?;
    let mut options = ConvertOptions {
        topics: args.topics.clone(),
        exclude,
        ..Default::default()
    };
    args.files.apply(&mut options.write);
    let input = if inputs.len() == 1 {
        inputs.into_iter().next().ok_or("no input")?
    } else {
        Bag::merge(inputs)
    };
    let converted = shm_bag::convert(&input, &args.output, &options)?;
    for type_name in &converted.without_definition {
        eprintln!(
            "{type_name}: the input keeps no definition of it and it is not a standard type: \
             its schema in the new bag is empty"
        );
    }
    let metadata = &converted.metadata;
    println!(
        "Converted {} on {} into {} ({})",
        counted(metadata.message_count, "message"),
        counted(metadata.topics_with_message_count.len() as u64, "topic"),
        args.output.display(),
        counted(metadata.relative_file_paths.len() as u64, "file")
    );
    Ok(())
}

fn reindex(dir: &std::path::Path) -> Result<(), Error> {
    let done = shm_bag::reindex(dir)?;
    for file in &done.files {
        if !file.rewritten {
            println!("{}: whole, {} messages", file.path.display(), file.messages);
            continue;
        }
        let mut said = format!(
            "{}: rewritten with {} messages (the unfinished file is kept as {}.unfinished)",
            file.path.display(),
            file.messages,
            file.path.file_name().unwrap_or_default().to_string_lossy()
        );
        if file.damaged_chunks > 0 {
            said += &format!("; {} damaged chunks left out", file.damaged_chunks);
            for damage in &file.damage {
                said += &format!("\n  {damage}");
            }
        }
        if let Some(cut) = &file.cut {
            said += &format!("; the file ends inside a record ({cut}): what followed was lost");
        }
        println!("{said}");
    }
    println!(
        "{}: {} on {}",
        dir.join(shm_bag::metadata::FILE_NAME).display(),
        counted(done.metadata.message_count, "message"),
        counted(
            done.metadata.topics_with_message_count.len() as u64,
            "topic"
        )
    );
    Ok(())
}

fn regex(flag: &str, text: Option<String>) -> Result<Option<regex::Regex>, Error> {
    text.map(|t| regex::Regex::new(&t).map_err(|e| format!("{flag} {t:?}: {e}").into()))
        .transpose()
}

fn record(context: &Context, args: RecordArgs) -> Result<(), Error> {
    let selection = Selection {
        all: args.all_topics || args.all,
        all_services: args.all_services || args.all,
        services: args.services,
        topics: args.topics,
        regex: regex("-e", args.regex)?,
        exclude: regex("-x", args.exclude_regex)?,
        include_hidden: args.include_hidden_topics,
    };
    let output = args.output.unwrap_or_else(|| {
        PathBuf::from(
            chrono::Local::now()
                .format("rosbag2_%Y_%m_%d-%H_%M_%S")
                .to_string(),
        )
    });
    let mut options = RecordOptions::new(&output, selection);
    options.domain_id = Some(context.domain_id);
    options.distro = Some(context.distro);
    options.type_timeout = context.timeout;
    options.max_queued_bytes = args.max_cache_size;
    options.interfaces = context.local.clone();
    args.files.apply(&mut options.write);
    options.start_paused = args.start_paused;
    options.snapshot = args.snapshot_mode;
    let snapshot_mode = args.snapshot_mode;
    let stop = crate::interrupted()?;
    let recorder = Recorder::start(&context.session, options)?;
    let control = recorder.control();
    let keys = if args.disable_keyboard_controls {
        None
    } else {
        let control = control.clone();
        crate::keyboard::start(crate::keyboard::RECORD_HELP, move |key| {
            crate::keyboard::record_key(&control, key)
        })
    };
    let started = Instant::now();
    let deadline = args
        .duration
        .map(|s| started + Duration::from_secs_f64(s.max(0.0)));
    let progress = (!args.no_progress).then(|| {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        bar
    });
    let mut last = (Instant::now(), 0u64);
    while !stop.load(Ordering::Relaxed) && deadline.is_none_or(|d| Instant::now() < d) {
        std::thread::sleep(Duration::from_millis(200));
        if recorder.stats().failure.is_some() {
            break; // a full disk, say: the totals and the error follow
        }
        if let Some(bar) = &progress {
            let stats = recorder.stats();
            let now = Instant::now();
            let rate = (stats.bytes - last.1) as f64 / now.duration_since(last.0).as_secs_f64();
            if now.duration_since(last.0) >= Duration::from_secs(1) {
                last = (now, stats.bytes);
            }
            bar.set_message(format!(
                "{} {}: {}, {}, {}/s | dropped {} | missed {}{}{}{}",
                if control.is_paused() {
                    "Paused:"
                } else {
                    "Recording"
                },
                counted(stats.topics as u64, "topic"),
                counted(stats.written, "message"),
                size(stats.bytes),
                size(rate as u64),
                stats.dropped,
                stats.missed,
                if snapshot_mode {
                    format!(" | held for a snapshot: {}", stats.buffered)
                } else {
                    String::new()
                },
                if stats.skipped.is_empty() {
                    String::new()
                } else {
                    format!(" | not recorded: {}", stats.skipped.len())
                },
                match stats
                    .channels
                    .iter()
                    .filter(|c| c.definition == shm_bag::TypeDefinition::Learning)
                    .count()
                {
                    0 => String::new(),
                    learning => format!(" | learning {}", counted(learning as u64, "type")),
                }
            ));
            bar.tick();
        }
    }
    drop(keys);
    let stopped = recorder.stop();
    let stats = control.stats();
    if let Some(bar) = progress {
        bar.finish_and_clear();
    }
    let seconds = started.elapsed().as_secs_f64();
    match &stopped {
        Ok(metadata) => eprintln!(
            "Recorded {} on {} ({}) into {} in {seconds:.1} s; dropped {}, missed {}",
            counted(metadata.message_count, "message"),
            counted(metadata.topics_with_message_count.len() as u64, "topic"),
            size(stats.bytes),
            output.display(),
            stats.dropped,
            stats.missed,
        ),
        Err(_) => eprintln!(
            "Recorded {} messages ({}) into {} in {seconds:.1} s before writing failed; dropped {}, missed {}",
            stats.written,
            size(stats.bytes),
            output.display(),
            stats.dropped,
            stats.missed,
        ),
    }
    if stats.buffered > 0 {
        eprintln!(
            "Not written: {} messages held for a snapshot that was not taken",
            stats.buffered
        );
    }
    for channel in &stats.channels {
        if let Some(line) = channel_summary(channel) {
            eprintln!("{line}");
        }
    }
    for (topic, why) in &stats.skipped {
        eprintln!("Not recorded: {topic}: {why}");
    }
    stopped.map(|_| ())
}

/// A line for a recorded topic and type that lost messages or was recorded
/// without its definition; `None` for one recorded whole.
fn channel_summary(channel: &shm_bag::ChannelStats) -> Option<String> {
    let missing = match &channel.definition {
        shm_bag::TypeDefinition::Missing(why) => Some(why.as_str()),
        _ => None,
    };
    if channel.dropped == 0 && channel.missed == 0 && missing.is_none() {
        return None;
    }
    let mut line = format!(
        "{} ({}): {} received, {} written, {} dropped, {} missed",
        channel.topic,
        channel.type_name,
        channel.received,
        channel.written,
        channel.dropped,
        channel.missed
    );
    if let Some(why) = missing {
        line += &format!("; recorded without its definition: {why}");
    }
    Some(line)
}

/// The playback's progress line, on stderr when it is a terminal: where the
/// playback is in the recording, its rate and whether it runs or is paused,
/// redrawn ten times a second until the returned flag is set.
fn play_progress(
    control: shm_bag::PlayerControl,
    start: u64,
    duration: u64,
) -> (
    indicatif::ProgressBar,
    std::sync::Arc<std::sync::atomic::AtomicBool>,
    std::thread::JoinHandle<()>,
) {
    use std::sync::atomic::{AtomicBool, Ordering};
    let bar = indicatif::ProgressBar::new(duration.max(1));
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{wide_bar}]")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let done = std::sync::Arc::new(AtomicBool::new(false));
    let updater = {
        let (bar, done) = (bar.clone(), done.clone());
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                let at = control.time().saturating_sub(start).min(duration);
                let state = if control.is_paused() {
                    "PAUSED"
                } else {
                    "RUNNING"
                };
                bar.set_position(at);
                bar.set_message(format!(
                    "{:.2}/{:.2} s at {}x [{state}]",
                    at as f64 / 1e9,
                    duration as f64 / 1e9,
                    control.rate()
                ));
                std::thread::sleep(Duration::from_millis(100));
            }
        })
    };
    (bar, done, updater)
}

fn play(context: &Context, args: &PlayArgs) -> Result<(), Error> {
    let bag = Bag::open(&args.bag_path)?;
    let span = bag.describe().map(|m| {
        let start = m.starting_time.nanoseconds_since_epoch;
        (start, m.duration.nanoseconds)
    });
    let seconds = |flag: &str, value: f64| {
        Duration::try_from_secs_f64(value)
            .map_err(|_| format!("{flag} {value}: give a number of seconds, 0 or more"))
    };
    let clock_on = if args.clock_topics_all {
        ClockTrigger::AllTopics
    } else if !args.clock_topics.is_empty() {
        ClockTrigger::Topics(args.clock_topics.clone())
    } else {
        ClockTrigger::Never
    };
    let options = PlayOptions {
        rate: args.rate,
        loop_playback: args.loop_playback,
        topics: args.topics.clone(),
        delay: seconds("--delay", args.delay)?,
        domain_id: Some(context.domain_id),
        distro: Some(context.distro),
        clock_hz: args.clock,
        clock_on,
        start_offset: seconds("--start-offset", args.start_offset)?,
        duration: (args.playback_duration >= 0.0)
            .then(|| seconds("--playback-duration", args.playback_duration))
            .transpose()?,
        start_paused: args.start_paused,
        ..PlayOptions::default()
    };
    let stop = crate::interrupted()?;
    let player = Player::new(&context.session, bag, options)?;
    let keys = if args.disable_keyboard_controls {
        None
    } else {
        let control = player.control();
        crate::keyboard::start(crate::keyboard::PLAY_HELP, move |key| {
            crate::keyboard::play_key(&control, key)
        })
    };
    let progress = match (args.no_progress, span) {
        (false, Ok((start, duration))) => Some(play_progress(player.control(), start, duration)),
        _ => None,
    };
    let stats = player.play(&stop);
    drop(keys);
    if let Some((bar, done, updater)) = progress {
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        let _ = updater.join();
        bar.finish_and_clear();
    }
    let stats = stats?;
    eprintln!(
        "Played {} messages ({}), {} from shared memory; {} failed",
        stats.published,
        size(stats.bytes),
        stats.shm,
        stats.failed
    );
    if stats.failed > 0 {
        return Err(format!("{} messages could not be published", stats.failed).into());
    }
    Ok(())
}

fn info(path: &std::path::Path, verbose: bool) -> Result<(), Error> {
    let bag = Bag::open(path)?;
    let metadata = bag.describe()?;
    let calls = if verbose {
        Some(service_calls(&bag)?)
    } else {
        None
    };
    print!("{}", format_info(&metadata, bag.size(), calls.as_ref()));
    println!();
    // metadata.yaml is read without the files: a file cut by a crash (or
    // still being recorded) is found by opening each, short of decompressing
    // whole files.
    if metadata.compression_mode != "file" {
        if let Err(e) = bag.topics() {
            eprintln!("WARNING: {e}");
        }
    }
    Ok(())
}

/// The service a recorded topic carries the events of, with the service's
/// type: a `<service>/_service_event` topic of a `pkg/srv/Name_Event` type.
fn recorded_service(name: &str, type_name: &str) -> Option<(String, String)> {
    let service = shm_bag::service_of_event_topic(name)?;
    let service_type = type_name.strip_suffix("_Event")?;
    service_type
        .contains("/srv/")
        .then(|| (service.to_owned(), service_type.to_owned()))
}

/// Each recorded service's requests and responses, by service: every event
/// read, a call counted once however many of its events (the client's and
/// the server's) were recorded.
fn service_calls(bag: &Bag) -> Result<BTreeMap<String, (u64, u64)>, Error> {
    use std::collections::HashSet;
    let services: BTreeMap<String, String> = bag
        .topics()?
        .iter()
        .filter_map(|t| {
            recorded_service(&t.name, &t.type_name).map(|(service, _)| (t.name.clone(), service))
        })
        .collect();
    // A call: the client's GID and the request's sequence number.
    type Calls = HashSet<Vec<u8>>;
    let mut seen: BTreeMap<String, (Calls, Calls)> = BTreeMap::new();
    bag.read(
        0,
        |_| {},
        |message| {
            if let Some(service) = services.get(message.topic) {
                // service_msgs/msg/ServiceEventInfo leads the event: its
                // event_type, stamp, client_gid and sequence_number.
                if let Ok(info) = shm_cdr::from_bytes::<ServiceEventInfo>(message.data) {
                    let call = [&info.client_gid[..], &info.sequence_number.to_le_bytes()].concat();
                    let entry = seen.entry(service.clone()).or_default();
                    match info.event_type {
                        ServiceEventInfo::REQUEST_SENT | ServiceEventInfo::REQUEST_RECEIVED => {
                            entry.0.insert(call);
                        }
                        _ => {
                            entry.1.insert(call);
                        }
                    }
                }
            }
            std::ops::ControlFlow::<()>::Continue(())
        },
    )?;
    Ok(seen
        .into_iter()
        .map(|(service, (requests, responses))| {
            (service, (requests.len() as u64, responses.len() as u64))
        })
        .collect())
}

/// ros2bag's `info` text (rosbag2_py's `format_bag_meta_data`).
fn format_info(
    metadata: &BagMetadata,
    bag_size: u64,
    calls: Option<&BTreeMap<String, (u64, u64)>>,
) -> String {
    const INDENT: &str = "                   ";
    let start = metadata.starting_time.nanoseconds_since_epoch;
    let end = start + metadata.duration.nanoseconds;
    let mut out = String::from("\nFiles:             ");
    for (i, file) in metadata.relative_file_paths.iter().enumerate() {
        if i > 0 {
            out.push_str(INDENT);
        }
        out.push_str(file);
        out.push('\n');
    }
    if metadata.relative_file_paths.is_empty() {
        out.push('\n');
    }
    let distro = if metadata.ros_distro.is_empty() {
        "unknown"
    } else {
        &metadata.ros_distro
    };
    out.push_str(&format!("Bag size:          {}\n", size(bag_size)));
    out.push_str(&format!(
        "Storage id:        {}\n",
        metadata.storage_identifier
    ));
    out.push_str(&format!("ROS Distro:        {distro}\n"));
    out.push_str(&format!(
        "Duration:          {}s\n",
        seconds(metadata.duration.nanoseconds)
    ));
    out.push_str(&format!("Start:             {}\n", time_point(start)));
    out.push_str(&format!("End:               {}\n", time_point(end)));
    out.push_str(&format!("Messages:          {}\n", metadata.message_count));
    out.push_str("Topic information: ");
    let (services, mut topics): (Vec<_>, Vec<_>) =
        metadata.topics_with_message_count.iter().partition(|t| {
            recorded_service(&t.topic_metadata.name, &t.topic_metadata.type_name).is_some()
        });
    topics.sort_by(|a, b| a.topic_metadata.name.cmp(&b.topic_metadata.name));
    if topics.is_empty() {
        out.push('\n');
    }
    for (i, topic) in topics.iter().enumerate() {
        if i > 0 {
            out.push_str(INDENT);
        }
        out.push_str(&format!(
            "Topic: {} | Type: {} | Count: {} | Serialization Format: {}\n",
            topic.topic_metadata.name,
            topic.topic_metadata.type_name,
            topic.message_count,
            topic.topic_metadata.serialization_format
        ));
    }
    out.push_str(&format!("Service:           {}\n", services.len()));
    out.push_str("Service information: ");
    let mut services: Vec<_> = services
        .into_iter()
        .filter_map(|t| {
            let (service, service_type) =
                recorded_service(&t.topic_metadata.name, &t.topic_metadata.type_name)?;
            Some((service, service_type, t))
        })
        .collect();
    services.sort_by(|a, b| a.0.cmp(&b.0));
    for (i, (service, service_type, topic)) in services.iter().enumerate() {
        if i > 0 {
            out.push_str("                     ");
        }
        let counts = match calls {
            Some(calls) => {
                let (requests, responses) = calls.get(service).copied().unwrap_or_default();
                format!("Request Count: {requests} | Response Count: {responses}")
            }
            None => format!("Event Count: {}", topic.message_count),
        };
        out.push_str(&format!(
            "Service: {service} | Type: {service_type} | {counts} | Serialization Format: {}\n",
            topic.topic_metadata.serialization_format
        ));
    }
    out
}

/// `12.345678901`: seconds with nine decimals.
fn seconds(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

/// `Mar  5 2024 10:00:00.000000000 (1709632800.000000000)`, in local time.
fn time_point(ns: u64) -> String {
    let secs = i64::try_from(ns / 1_000_000_000).unwrap_or(i64::MAX);
    let local = chrono::DateTime::from_timestamp(secs, 0)
        .map(|t| {
            t.with_timezone(&chrono::Local)
                .format("%b %e %Y %H:%M:%S")
                .to_string()
        })
        .unwrap_or_default();
    format!("{local}.{:09} ({})", ns % 1_000_000_000, seconds(ns))
}

/// rosbag2's sizes: `B` with no decimals, else one decimal of KiB, MiB, …
fn size(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit < 4 {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}
