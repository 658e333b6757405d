//! `shm-ros2 topic …`: ros2topic's verbs and output.

use std::collections::{BTreeMap, VecDeque};
use std::io::Write;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use clap::{Args, Subcommand};
use shm_cdr::describe::Container;
use shm_cdr::dynamic::{DynamicType, Element, FieldDef, Value, YamlOptions};
use shm_runtime::graph::Graph;
use shm_runtime::rmw::{Durability, EntityKind, Liveliness, Qos, Reliability};
use zenoh::Wait;

use crate::context::{is_hidden, Context};
use crate::{types, Error};

#[derive(Debug, Subcommand)]
pub(crate) enum TopicCommand {
    /// Output a list of available topics.
    List {
        /// Additionally show the topic type.
        #[arg(short = 't', long)]
        show_types: bool,
        /// Only display the number of topics discovered.
        #[arg(short = 'c', long)]
        count_topics: bool,
        /// Consider hidden topics as well.
        #[arg(long)]
        include_hidden_topics: bool,
    },
    /// Print information about a topic.
    Info {
        /// Name of the ROS topic to get info (e.g. '/chatter').
        topic_name: String,
        /// Print detailed information about the publishers and subscribers.
        #[arg(short, long)]
        verbose: bool,
    },
    /// Print a topic's type.
    Type {
        /// Name of the ROS topic (e.g. '/chatter').
        topic_name: String,
    },
    /// Output messages from a topic.
    Echo(EchoArgs),
    /// Print the average publishing rate to screen.
    Hz {
        /// Name of the ROS topic to listen to (e.g. '/chatter').
        topic_name: String,
        /// Window size, in # of messages, for calculating rate.
        #[arg(short, long = "window", default_value_t = 10_000)]
        window: usize,
    },
    /// Display bandwidth used by topic.
    Bw {
        /// Name of the ROS topic to listen to (e.g. '/chatter').
        topic_name: String,
        /// Maximum window size, in # of messages, for calculating rate.
        #[arg(short, long = "window", default_value_t = 100)]
        window: usize,
    },
    /// Publish a message to a topic.
    Pub(PubArgs),
    /// Show how a topic's messages reach this process, from each publisher:
    /// in shared memory (read where the publisher wrote them) or copied.
    Shm {
        /// Name of the ROS topic to listen to (e.g. '/camera/image').
        topic_name: String,
        /// Stop after this many messages and print the totals once
        /// (default: print them every second, until Ctrl-C).
        #[arg(short = 'n', long = "messages")]
        messages: Option<u64>,
    },
}

#[derive(Debug, Args)]
pub(crate) struct EchoArgs {
    /// Name of the ROS topic to listen to (e.g. '/chatter').
    topic_name: String,
    /// Type of the ROS message (e.g. 'std_msgs/msg/String'); by default the
    /// type its publishers announce.
    message_type: Option<String>,
    /// Print the first message received and then exit.
    #[arg(long)]
    once: bool,
    /// The length to truncate arrays, bytes, and strings to.
    #[arg(short = 'l', long, default_value_t = 128)]
    truncate_length: usize,
    /// Output all elements for arrays, bytes, and string with a length >
    /// '--truncate-length'.
    #[arg(short = 'f', long)]
    full_length: bool,
    /// Don't print array fields of messages.
    #[arg(long)]
    no_arr: bool,
    /// Don't print string fields of messages.
    #[arg(long)]
    no_str: bool,
    /// Print arrays and sequences in flow style.
    #[arg(long)]
    flow_style: bool,
    /// Print each message as one line of JSON instead of YAML.
    #[arg(long, conflicts_with_all = ["flow_style", "no_arr", "no_str", "field"])]
    json: bool,
    /// Echo a selected field of a message. Use '.' to select sub-fields. For
    /// example, to echo the position field of a nav_msgs/msg/Odometry
    /// message: 'shm-ros2 topic echo /odom --field pose.pose.position'.
    #[arg(long)]
    field: Option<String>,
}

#[derive(Debug, Args)]
pub(crate) struct PubArgs {
    /// Name of the ROS topic to publish to (e.g. '/chatter').
    topic_name: String,
    /// Type of the ROS message (e.g. 'std_msgs/String').
    message_type: String,
    /// Values to fill the message with in YAML format (e.g. 'data: Hello
    /// World'), otherwise the message is published with default values.
    #[arg(default_value = "{}")]
    values: String,
    /// Publishing rate in Hz.
    #[arg(short, long, default_value_t = 1.0)]
    rate: f64,
    /// Publish one message and exit.
    #[arg(short = '1', long)]
    once: bool,
    /// Publish this number of times and then exit.
    #[arg(short, long)]
    times: Option<u64>,
    /// Wait until this many subscriptions match before the first message
    /// (within the timeout).
    #[arg(short, long, default_value_t = 1)]
    wait_matching_subscriptions: usize,
}

impl TopicCommand {
    /// Whether the verb waits for what it reads or serves (echo, hz, bw,
    /// pub), and so may start before the system it talks to.
    pub(crate) fn waits(&self) -> bool {
        matches!(
            self,
            Self::Echo(_) | Self::Hz { .. } | Self::Bw { .. } | Self::Pub(_) | Self::Shm { .. }
        )
    }
}

pub(crate) fn run(context: &Context, command: TopicCommand) -> Result<(), Error> {
    match command {
        TopicCommand::List {
            show_types,
            count_topics,
            include_hidden_topics,
        } => {
            let graph = context.graph();
            let topics: Vec<_> = graph
                .topics()
                .into_iter()
                .filter(|(name, _)| include_hidden_topics || !is_hidden(name))
                .collect();
            let mut out = std::io::stdout().lock();
            if count_topics {
                writeln!(out, "{}", topics.len())?;
                return Ok(());
            }
            for (name, types) in topics {
                if show_types {
                    let types: Vec<&str> = types.iter().map(String::as_str).collect();
                    writeln!(out, "{name} [{}]", types.join(", "))?;
                } else {
                    writeln!(out, "{name}")?;
                }
            }
            Ok(())
        }
        TopicCommand::Info {
            topic_name,
            verbose,
        } => info(context, &topic_name, verbose),
        TopicCommand::Type { topic_name } => {
            let graph = context.graph();
            let Some(types) = graph.topics().remove(&topic_name) else {
                return Err(format!("Unknown topic '{topic_name}'").into());
            };
            for ty in types {
                println!("{ty}");
            }
            Ok(())
        }
        TopicCommand::Echo(args) => echo(context, args),
        TopicCommand::Hz { topic_name, window } => hz(context, &topic_name, window),
        TopicCommand::Bw { topic_name, window } => bw(context, &topic_name, window),
        TopicCommand::Pub(args) => publish(context, args),
        TopicCommand::Shm {
            topic_name,
            messages,
        } => shm_use(context, &topic_name, messages),
    }
}

fn info(context: &Context, topic: &str, verbose: bool) -> Result<(), Error> {
    let graph = context.graph();
    let Some(types) = graph.topics().remove(topic) else {
        return Err(format!("Unknown topic '{topic}'").into());
    };
    let end = if verbose { "\n\n" } else { "\n" };
    let types: Vec<String> = types.into_iter().collect();
    let type_text = match &types[..] {
        [one] => one.clone(),
        many => format!("{many:?}"),
    };
    let mut out = std::io::stdout().lock();
    write!(out, "Type: {type_text}{end}")?;
    for (kind, label) in [
        (EntityKind::Publisher, "Publisher count"),
        (EntityKind::Subscriber, "Subscription count"),
    ] {
        let endpoints = graph.endpoints(kind, topic);
        write!(out, "{label}: {}{end}", endpoints.len())?;
        if verbose {
            for entity in endpoints {
                let Some(endpoint) = &entity.endpoint else {
                    continue;
                };
                let qos = &endpoint.qos;
                write!(
                    out,
                    "Node name: {}\nNode namespace: {}\nTopic type: {}\nTopic type hash: {}\nEndpoint type: {}\nGID: {}\nQoS profile:\n  Reliability: {}\n  History (Depth): {}\n  Durability: {}\n  Lifespan: {}\n  Deadline: {}\n  Liveliness: {}\n  Liveliness lease duration: {}{end}",
                    entity.node_name,
                    entity.namespace,
                    endpoint.type_name,
                    endpoint.type_hash,
                    if kind == EntityKind::Publisher { "PUBLISHER" } else { "SUBSCRIPTION" },
                    entity.gid.0.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join("."),
                    match qos.reliability {
                        Reliability::Reliable => "RELIABLE",
                        Reliability::BestEffort => "BEST_EFFORT",
                        Reliability::BestAvailable => "BEST_AVAILABLE",
                    },
                    match qos.history {
                        shm_runtime::rmw::History::KeepLast(depth) => format!("KEEP_LAST ({depth})"),
                        shm_runtime::rmw::History::KeepAll => "KEEP_ALL".to_owned(),
                    },
                    match qos.durability {
                        Durability::TransientLocal => "TRANSIENT_LOCAL",
                        Durability::Volatile => "VOLATILE",
                        Durability::BestAvailable => "BEST_AVAILABLE",
                    },
                    qos_duration(qos.lifespan),
                    qos_duration(qos.deadline),
                    match qos.liveliness {
                        Liveliness::Automatic => "AUTOMATIC",
                        Liveliness::ManualByTopic => "MANUAL_BY_TOPIC",
                        Liveliness::BestAvailable => "BEST_AVAILABLE",
                    },
                    qos_duration(qos.liveliness_lease),
                )?;
            }
        }
    }
    Ok(())
}

/// A QoS duration as rclpy prints it (`rclpy.duration.Duration.__str__`):
/// `Infinite` for none (rmw_zenoh_cpp's default, `RMW_DURATION_INFINITE`) and
/// for anything at or past it, else the nanoseconds.
fn qos_duration(duration: Option<Duration>) -> String {
    match duration.map(|d| d.as_nanos()) {
        Some(nanos) if nanos < i64::MAX as u128 => format!("{nanos} nanoseconds"),
        _ => "Infinite".to_owned(),
    }
}

/// The topic's type: the one given (a standard type), else the one its
/// endpoints announce.
fn resolve_type(
    context: &Context,
    graph: &Graph,
    topic: &str,
    given: Option<&str>,
) -> Result<DynamicType, Error> {
    match given {
        Some(name) => types::message_by_name(context, name)?.ok_or_else(|| {
            format!(
                "{name} is not a standard type this binary knows nor in --interfaces{}: leave the type out, and it is asked of the node that uses {topic}",
                types::did_you_mean(name)
            )
            .into()
        }),
        None => types::of_topic(context, graph, topic),
    }
}

/// The QoS to subscribe with, as ros2cli picks it: the publishers' (transient
/// local if they all are; best effort if any is).
fn subscriber_qos(graph: &Graph, topic: &str) -> Qos {
    let publishers: Vec<Qos> = graph
        .publishers(topic)
        .iter()
        .filter_map(|e| e.endpoint.as_ref().map(|e| e.qos))
        .collect();
    let mut qos = Qos::default();
    if !publishers.is_empty()
        && publishers
            .iter()
            .all(|q| q.durability == Durability::TransientLocal)
    {
        qos.durability = Durability::TransientLocal;
    }
    if publishers
        .iter()
        .any(|q| q.reliability == Reliability::BestEffort)
    {
        qos.reliability = Reliability::BestEffort;
    }
    qos
}

/// Wait for the topic to appear on the graph (it may be starting).
/// The graph once `topic` has an endpoint whose type can be read, waiting for
/// one as ros2topic's `hz` and `bw` do: after `--timeout` without one, its
/// warning (on stdout, as ros2topic prints it), then as long as it takes.
fn graph_with_endpoints(context: &Context, topic: &str) -> Result<Graph, Error> {
    let graph = graph_with_topic(context, topic);
    let has_endpoints =
        |g: &Graph| !g.publishers(topic).is_empty() || !g.subscribers(topic).is_empty();
    if has_endpoints(&graph) {
        return Ok(graph);
    }
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "WARNING: topic [{topic}] does not appear to be published yet"
    )?;
    out.flush()?;
    loop {
        if let Some(graph) = context.wait_for(has_endpoints) {
            return Ok(graph);
        }
        if context.timeout.is_zero() {
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

fn graph_with_topic(context: &Context, topic: &str) -> Graph {
    context
        .wait_for(|g| !g.publishers(topic).is_empty())
        .unwrap_or_else(|| context.graph())
}

fn echo(context: &Context, args: EchoArgs) -> Result<(), Error> {
    let graph = graph_with_topic(context, &args.topic_name);
    let ty = resolve_type(
        context,
        &graph,
        &args.topic_name,
        args.message_type.as_deref(),
    )?;
    let subscriber = context
        .node()?
        .declare_dynamic_subscriber(
            &args.topic_name,
            &ty,
            subscriber_qos(&graph, &args.topic_name),
        )
        .wait()?;
    if let Some(others) = other_types(&graph, &args.topic_name, EntityKind::Publisher, &ty) {
        eprintln!(
            "WARNING: {others}: this command hears none of them. Without a type, \
             `shm-ros2 topic echo {}` takes the one its publishers announce. Still waiting.",
            args.topic_name
        );
    }
    let options = YamlOptions::echo()
        .truncate_length((!args.full_length).then_some(args.truncate_length))
        .no_arr(args.no_arr)
        .no_str(args.no_str)
        .flow_style(args.flow_style);
    let path = args
        .field
        .as_deref()
        .map(|text| field_path(&ty, text))
        .transpose()?;
    let mut out = std::io::stdout().lock();
    let mut first = true;
    loop {
        let sample = if first {
            first = false;
            match subscriber.recv_timeout(context.timeout)? {
                Some(sample) => sample,
                None => {
                    silent_publishers(context, &args.topic_name, &ty);
                    subscriber.recv()?
                }
            }
        } else {
            subscriber.recv()?
        };
        let bytes = sample.payload().to_bytes();
        // Shared memory another process may write is read as such.
        let shared = sample.is_shm();
        // Printed cut to `truncate_length` elements (or with `--no-arr`,
        // none), a message is decoded cut too, and JSON is written as the
        // bytes are read: memory follows what is printed, whatever the
        // message's shape.
        let keep = match (args.no_arr, options.truncate_length) {
            (true, _) => 0,
            (false, Some(keep)) => keep,
            (false, None) => usize::MAX,
        };
        let text = match &path {
            Some(path) => echo_field(&ty, &bytes, shared, path, &options),
            None if args.json => match ty.serialize_cdr(&bytes, shared) {
                Ok(streamed) => {
                    let mut line = std::io::BufWriter::with_capacity(64 << 10, &mut out);
                    serde_json::to_writer(&mut line, &streamed).map_err(std::io::Error::from)?;
                    line.write_all(b"\n")?;
                    line.flush()?;
                    Ok(String::new())
                }
                Err(e) => Err(e.into()),
            },
            None => match ty.decode_truncated(&bytes, shared, keep) {
                Ok(message) => Ok(format!("{}---\n", message.to_yaml_with(&options))),
                Err(e) => Err(e.into()),
            },
        };
        match text {
            Ok(text) => out.write_all(text.as_bytes())?,
            Err(e) => eprintln!(
                "a message on {} is not a {}: {e}",
                args.topic_name,
                ty.name()
            ),
        }
        out.flush()?;
        if args.once {
            return Ok(());
        }
    }
}

/// Whether `entity` is an endpoint of `ty` (its hash unless it announces
/// none, as Humble's do).
fn carries(entity: &shm_runtime::graph::Entity, ty: &DynamicType, hash: &str) -> bool {
    entity.endpoint.as_ref().is_some_and(|e| {
        e.type_name == ty.name() && (e.type_hash.is_empty() || e.type_hash == hash)
    })
}

/// The endpoints of `kind` on `topic` when none of them carries `ty`, said
/// as what they carry: a ROS 2 publisher and subscription meet only when
/// type and hash agree, so a command with another type reaches none of them.
fn other_types(graph: &Graph, topic: &str, kind: EntityKind, ty: &DynamicType) -> Option<String> {
    let endpoints = graph.endpoints(kind, topic);
    let hash = ty.type_hash();
    if endpoints.is_empty() || endpoints.iter().any(|e| carries(e, ty, &hash)) {
        return None;
    }
    let mut carried: Vec<String> = endpoints
        .iter()
        .filter_map(|e| e.endpoint.as_ref())
        .map(|e| match e.type_name == ty.name() {
            true => format!("{} with type hash {}", e.type_name, e.type_hash),
            false => e.type_name.clone(),
        })
        .collect();
    carried.sort();
    carried.dedup();
    let ours = match carried.iter().any(|c| c.starts_with(ty.name())) {
        true => format!(
            "{} with type hash {hash} (another distribution or package version)",
            ty.name()
        ),
        false => ty.name().to_owned(),
    };
    let role = match kind {
        EntityKind::Publisher => "publisher",
        _ => "subscriber",
    };
    Some(format!(
        "{topic} has {}, of {}, not {ours}",
        crate::counted(endpoints.len() as u64, role),
        carried.join(" and ")
    ))
}

/// Say on stderr, once, why a topic with publishers may send nothing, where
/// `echo` would otherwise wait without a word.
fn silent_publishers(context: &Context, topic: &str, ty: &DynamicType) {
    let hash = ty.type_hash();
    let publishers = context
        .graph()
        .publishers(topic)
        .iter()
        .filter(|p| carries(p, ty, &hash))
        .count();
    if publishers > 0 {
        eprintln!(
            "No message on {topic} in {:.0} s from its {publishers} publisher(s): they may \
             publish rarely, or a Zenoh access-control policy (the router's, or the one in \
             this command's Zenoh configuration) denies this topic to it. Still waiting.",
            context.timeout.as_secs_f64()
        );
    }
}

/// `--field`'s names, checked against the type: each but the last names a
/// message, as ros2topic finds them with `getattr`, and its error when one
/// is not there.
struct FieldPath {
    names: Vec<String>,
    /// The last field's definition.
    field: FieldDef,
}

fn field_path(ty: &DynamicType, text: &str) -> Result<FieldPath, Error> {
    let names: Vec<String> = text
        .split('.')
        .filter(|name| !name.is_empty())
        .map(str::to_owned)
        .collect();
    let invalid = |owner: &str, name: &str| -> Error {
        format!(
            "Invalid field '{}': '{owner}' object has no attribute '{name}'",
            names.join(".")
        )
        .into()
    };
    let mut def = ty.root();
    // A field before the next name that is not a message.
    let mut value: Option<&FieldDef> = None;
    for (i, name) in names.iter().enumerate() {
        if let Some(value) = value {
            return Err(invalid(python_type(value), name));
        }
        let Some(field) = def.fields.iter().find(|f| &f.name == name) else {
            let short = def.name.rsplit('/').next().unwrap_or_default();
            return Err(invalid(short, name));
        };
        if i + 1 == names.len() {
            let field = field.clone();
            return Ok(FieldPath { names, field });
        }
        match (field.element, field.container) {
            (Element::Message(index), Container::Single) => {
                def = ty.structs().get(index).ok_or("a nested type is missing")?;
            }
            _ => value = Some(field),
        }
    }
    Err(format!("Invalid field value '{text}'").into())
}

/// The Python type rclpy holds a field that is not a message in, for
/// ros2topic's error.
fn python_type(field: &FieldDef) -> &'static str {
    match (field.element, field.container) {
        (Element::Bool, Container::Single) => "bool",
        (Element::F32 | Element::F64, Container::Single) => "float",
        (Element::Byte, Container::Single) => "bytes",
        (Element::String(_) | Element::WString(_), Container::Single) => "str",
        (Element::Message(_), Container::Single) => "object",
        (_, Container::Single) => "int",
        (Element::Bool | Element::Byte | Element::Char, _)
        | (Element::String(_) | Element::WString(_) | Element::Message(_), _) => "list",
        (_, Container::Array(_)) => "numpy.ndarray",
        (_, _) => "array.array",
    }
}

/// What ros2topic prints for the field at `path` of a message: a message
/// as YAML, anything else as Python's `str` of it; that field alone is
/// decoded, the rest of the message checked and skipped.
fn echo_field(
    ty: &DynamicType,
    bytes: &[u8],
    shared: bool,
    path: &FieldPath,
    options: &YamlOptions,
) -> Result<String, Error> {
    let names: Vec<&str> = path.names.iter().map(String::as_str).collect();
    match ty.decode_field(bytes, shared, &names)? {
        Some(Value::Message(nested)) => Ok(format!("{}---\n", nested.to_yaml_with(options))),
        Some(value) => Ok(format!(
            "{}\n---\n",
            crate::python::value_str(&path.field, &value, ty)
        )),
        None => Err(format!("no field {}", names.join(".")).into()),
    }
}

/// A subscriber to `topic` with its announced type and ros2cli's QoS, for
/// the verbs that count messages without reading them.
fn subscribe(
    context: &Context,
    topic: &str,
) -> Result<shm_runtime::RosSubscriber<DynamicType>, Error> {
    let graph = graph_with_endpoints(context, topic)?;
    let ty = types::of_topic(context, &graph, topic)?;
    let subscriber = context
        .node()?
        .declare_dynamic_subscriber(topic, &ty, subscriber_qos(&graph, topic))
        .wait()?;
    Ok(subscriber)
}

fn hz(context: &Context, topic: &str, window: usize) -> Result<(), Error> {
    let subscriber = subscribe(context, topic)?;
    let mut deltas: VecDeque<f64> = VecDeque::new();
    let mut last: Option<Instant> = None;
    let mut received = 0u64;
    let mut printed = 0u64;
    let mut next_report = Instant::now() + Duration::from_secs(1);
    let mut out = std::io::stdout().lock();
    loop {
        let wait = next_report.saturating_duration_since(Instant::now());
        if let Some(_sample) = subscriber.recv_timeout(wait)? {
            let now = Instant::now();
            if let Some(previous) = last {
                deltas.push_back(now.duration_since(previous).as_secs_f64());
                if deltas.len() > window {
                    deltas.pop_front();
                }
            }
            last = Some(now);
            received += 1;
        }
        if Instant::now() < next_report {
            continue;
        }
        next_report += Duration::from_secs(1);
        if deltas.is_empty() || received == printed {
            continue;
        }
        printed = received;
        let n = deltas.len() as f64;
        let mean = deltas.iter().sum::<f64>() / n;
        let rate = if mean > 0.0 { 1.0 / mean } else { 0.0 };
        let std_dev = (deltas.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        let min = deltas.iter().copied().fold(f64::INFINITY, f64::min);
        let max = deltas.iter().copied().fold(0.0, f64::max);
        writeln!(
            out,
            "average rate: {rate:.3}\n\tmin: {min:.3}s max: {max:.3}s std dev: {std_dev:.5}s window: {}",
            deltas.len()
        )?;
        out.flush()?;
    }
}

fn bw(context: &Context, topic: &str, window: usize) -> Result<(), Error> {
    let subscriber = subscribe(context, topic)?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "Subscribed to [{topic}]")?;
    out.flush()?;
    let mut arrivals: VecDeque<(Instant, usize)> = VecDeque::new();
    let mut next_report = Instant::now() + Duration::from_secs(1);
    loop {
        let wait = next_report.saturating_duration_since(Instant::now());
        if let Some(sample) = subscriber.recv_timeout(wait)? {
            arrivals.push_back((Instant::now(), sample.payload().len()));
            if arrivals.len() > window {
                arrivals.pop_front();
            }
        }
        if Instant::now() < next_report {
            continue;
        }
        next_report += Duration::from_secs(1);
        let (Some(first), true) = (arrivals.front(), arrivals.len() >= 2) else {
            continue;
        };
        let elapsed = first.0.elapsed().as_secs_f64();
        let total: usize = arrivals.iter().map(|(_, size)| size).sum();
        let n = arrivals.len();
        let per_second = total as f64 / elapsed;
        let mean = total as f64 / n as f64;
        let min = arrivals.iter().map(|(_, s)| *s).min().unwrap_or(0) as f64;
        let max = arrivals.iter().map(|(_, s)| *s).max().unwrap_or(0) as f64;
        let unit = |bytes: f64| {
            if per_second < 1000.0 {
                format!("{bytes:.0} B")
            } else if per_second < 1_000_000.0 {
                format!("{:.2} KB", bytes / 1000.0)
            } else {
                format!("{:.2} MB", bytes / 1000.0 / 1000.0)
            }
        };
        writeln!(
            out,
            "{}/s from {n} messages\n\tMessage size mean: {} min: {} max: {}",
            unit(per_second),
            unit(mean),
            unit(min),
            unit(max)
        )?;
        out.flush()?;
    }
}

/// How many messages arrived, and how many bytes of them, in shared memory
/// and copied.
#[derive(Default)]
struct Arrivals {
    messages: u64,
    in_shm: u64,
    shm_bytes: u64,
    copied_bytes: u64,
}

impl Arrivals {
    fn add(&mut self, len: usize, shm_len: usize) {
        let len = len as u64;
        let shm_len = (shm_len as u64).min(len);
        self.messages += 1;
        if shm_len > 0 {
            self.in_shm += 1;
        }
        self.shm_bytes += shm_len;
        self.copied_bytes += len - shm_len;
    }
}

impl std::fmt::Display for Arrivals {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let percent = |part: u64| {
            if self.messages == 0 {
                0.0
            } else {
                100.0 * part as f64 / self.messages as f64
            }
        };
        write!(
            f,
            "{} messages: {} in shared memory ({:.0}%, {} bytes), {} copied ({:.0}%, {} bytes)",
            self.messages,
            self.in_shm,
            percent(self.in_shm),
            self.shm_bytes,
            self.messages - self.in_shm,
            percent(self.messages - self.in_shm),
            self.copied_bytes
        )
    }
}

/// `topic shm`: each message of `topic` counted as it arrives here, in
/// shared memory or copied, by the publisher its attachment names; the totals
/// every second, or once after `limit` messages. A subscriber of bytes alone:
/// no type needs to be known.
fn shm_use(context: &Context, topic: &str, limit: Option<u64>) -> Result<(), Error> {
    let graph = graph_with_endpoints(context, topic)?;
    let endpoint = graph
        .publishers(topic)
        .into_iter()
        .chain(graph.subscribers(topic))
        .find_map(|e| e.endpoint.clone())
        .ok_or_else(|| format!("topic {topic}: its endpoints announce no type"))?;
    let subscriber = context
        .node()?
        .declare_serialized_subscriber(
            topic,
            &endpoint.type_name,
            &endpoint.type_hash,
            subscriber_qos(&graph, topic),
        )
        .wait()?;
    let mut total = Arrivals::default();
    let mut by_publisher: BTreeMap<Option<[u8; 16]>, Arrivals> = BTreeMap::new();
    let mut printed = 0;
    let mut next_report = Instant::now() + Duration::from_secs(1);
    let mut out = std::io::stdout().lock();
    loop {
        let wait = next_report.saturating_duration_since(Instant::now());
        if let Some(sample) = subscriber.recv_timeout(wait)? {
            let (len, shm_len) = (sample.payload().len(), sample.shm_len());
            let gid = sample.attachment().and_then(Result::ok).map(|a| a.gid.0);
            total.add(len, shm_len);
            by_publisher.entry(gid).or_default().add(len, shm_len);
        }
        let done = limit.is_some_and(|n| total.messages >= n);
        if !done && (limit.is_some() || Instant::now() < next_report) {
            continue;
        }
        next_report += Duration::from_secs(1);
        if total.messages == printed && !done {
            continue;
        }
        printed = total.messages;
        let graph = context.graph();
        writeln!(out, "{topic}: {total}")?;
        for (gid, arrivals) in &by_publisher {
            let who = gid
                .and_then(|gid| {
                    graph
                        .publishers(topic)
                        .into_iter()
                        .find(|e| e.gid.0 == gid)
                        .map(|e| e.node_fqn())
                })
                .unwrap_or_else(|| match gid {
                    // As `topic info -v` prints a GID.
                    Some(gid) => format!("publisher {}", gid.map(|b| format!("{b:02x}")).join(".")),
                    None => "publishers without an rmw_zenoh attachment".to_owned(),
                });
            writeln!(out, "  from {who}: {arrivals}")?;
        }
        out.flush()?;
        if done {
            return Ok(());
        }
    }
}

fn now() -> (i32, u32) {
    let since = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    (
        i32::try_from(since.as_secs()).unwrap_or(i32::MAX),
        since.subsec_nanos(),
    )
}

fn publish(context: &Context, args: PubArgs) -> Result<(), Error> {
    let ty = match types::message_by_name(context, &args.message_type)? {
        Some(ty) => ty,
        None => {
            // A type of the system's own: as its subscribers' nodes describe it.
            let graph = context
                .wait_for(|g| !g.subscribers(&args.topic_name).is_empty())
                .unwrap_or_else(|| context.graph());
            let hint = types::did_you_mean(&args.message_type);
            if graph.publishers(&args.topic_name).is_empty()
                && graph.subscribers(&args.topic_name).is_empty()
            {
                return Err(format!(
                    "The passed message type is invalid: {} is not a standard type this binary knows nor in --interfaces{hint}, and no node on {} uses a type whose description could be asked for",
                    args.message_type, args.topic_name
                )
                .into());
            }
            let ty = types::of_topic(context, &graph, &args.topic_name)?;
            if ty.name() != types::full_name(&args.message_type) {
                return Err(format!(
                    "The passed message type is invalid: {} is not a standard type{hint}, and {} carries {}",
                    args.message_type,
                    args.topic_name,
                    ty.name()
                )
                .into());
            }
            ty
        }
    };
    // Read once now, so that bad values are reported before anything is
    // declared.
    ty.message_from_yaml_at(&args.values, now())
        .map_err(|e| format!("Failed to populate field: {e}"))?;
    if !(args.rate > 0.0 && args.rate.is_finite()) {
        return Err(format!(
            "--rate {}: give a positive number of messages per second",
            args.rate
        )
        .into());
    }
    let times = if args.once { Some(1) } else { args.times };
    let publisher = context
        .node()?
        .declare_dynamic_publisher(&args.topic_name, &ty, Qos::default())
        .wait()?;
    let topic = publisher_topic(context, &args.topic_name);
    if let Some(others) = other_types(&context.graph(), &topic, EntityKind::Subscriber, &ty) {
        eprintln!("WARNING: {others}: none of them receives these messages.");
    }
    println!("publisher: beginning loop");
    if args.wait_matching_subscriptions > 0 {
        let deadline = Instant::now() + context.timeout;
        publisher.wait_for_subscribers(context.timeout);
        let node = context.node()?;
        while Instant::now() < deadline {
            let graph = node.graph(Duration::from_millis(100))?;
            if graph
                .subscribers(&publisher_topic(context, &args.topic_name))
                .len()
                >= args.wait_matching_subscriptions
            {
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    let period = Duration::from_secs_f64(1.0 / args.rate);
    let mut next = Instant::now();
    let mut count = 0u64;
    loop {
        let message = ty
            .message_from_yaml_at(&args.values, now())
            .map_err(|e| format!("Failed to populate field: {e}"))?;
        publisher.publish_dynamic(&message).wait()?;
        count += 1;
        println!(
            "publishing #{count}: {}\n",
            message
                .to_yaml_with(&YamlOptions::full().flow_style(true))
                .trim_end()
                .replace('\n', ", ")
        );
        if times.is_some_and(|t| count >= t) {
            // Give the last message time to leave.
            std::thread::sleep(Duration::from_millis(100));
            return Ok(());
        }
        next += period;
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
    }
}

/// The topic's fully qualified name, as the graph lists it.
fn publisher_topic(context: &Context, topic: &str) -> String {
    context
        .node()
        .ok()
        .and_then(|n| n.resolve_topic_name(topic).ok())
        .unwrap_or_else(|| topic.to_owned())
}
