//! Fuzz bodies for the readers of what other programs and files hand the
//! tools: type descriptions from any node, message and parameter text,
//! liveliness tokens, recordings. Each must give an answer or a clear error,
//! within bounded memory and stack, never a panic.

use std::io::Write;
use std::ops::ControlFlow;

use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::type_description_interfaces::msg::TypeDescription;
use shm_cdr::{encoded_size, from_bytes, to_vec};

/// `data` as a length-prefixed first part (4 bytes, little endian) and the
/// rest.
pub fn split(data: &[u8]) -> (&[u8], &[u8]) {
    let Some((len, rest)) = data.split_first_chunk::<4>() else {
        return (data, &[]);
    };
    let len = (u32::from_le_bytes(*len) as usize).min(rest.len());
    rest.split_at(len)
}

/// `first` and `rest` as [`split`] reads them.
pub fn join(first: &[u8], rest: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 + first.len() + rest.len());
    out.extend_from_slice(&u32::try_from(first.len()).unwrap_or(u32::MAX).to_le_bytes());
    out.extend_from_slice(first);
    out.extend_from_slice(rest);
    out
}

/// The longest YAML the targets read back: a description may give a
/// default of tens of megabytes, read back in seconds, not microseconds.
const MAX_YAML_ROUND_TRIP: usize = 1 << 20;

/// Target `type_description`: a CDR `TypeDescription` (what a node's
/// `~/get_type_description` answers), then a payload. A description that
/// builds is walked every way (default, encode, decode, view, YAML out and
/// back, hash, `.msg` texts); the payload is decoded and viewed alike.
pub fn type_description(data: &[u8]) {
    let (description, payload) = split(data);
    let Ok(description) = from_bytes::<TypeDescription>(description) else {
        return;
    };
    let Ok(ty) = DynamicType::from_type_description_msg(&description) else {
        return;
    };
    let default = ty.default_message();
    let bytes = to_vec(&default).expect("a default message encodes");
    assert_eq!(bytes.len(), encoded_size(&default));
    let decoded = ty.decode(&bytes);
    super::view_agrees(&ty, &bytes, &decoded);
    let decoded = decoded.expect("a default message decodes");
    assert_eq!(to_vec(&decoded).ok().as_deref(), Some(&bytes[..]));
    let yaml = default.to_yaml();
    if yaml.len() <= MAX_YAML_ROUND_TRIP {
        let back = ty
            .message_from_yaml(&yaml)
            .unwrap_or_else(|e| panic!("{}: its YAML does not read back: {e}\n{yaml}", ty.name()));
        assert_eq!(
            to_vec(&back).ok().as_deref(),
            Some(&bytes[..]),
            "{}: YAML round trip\n{yaml}",
            ty.name()
        );
    }
    assert!(ty.type_hash().starts_with("RIHS01_"));
    let _ = ty.msg_texts();
    let decoded = ty.decode(payload);
    super::view_agrees(&ty, payload, &decoded);
    if let Ok(message) = decoded {
        let again = to_vec(&message).expect("a decoded message re-encodes");
        assert_eq!(again.len(), encoded_size(&message));
        let _ = message.to_yaml();
    }
}

/// The standard message types the text targets read as: the first byte
/// picks one.
fn standard_type(pick: u8) -> Option<DynamicType> {
    let table = shm_bag::types::standard();
    let (_, known) = table.iter().nth(usize::from(pick) % table.len())?;
    DynamicType::from_description(&(known.describe)()).ok()
}

/// Target `message_text`: YAML or JSON text as `topic pub` reads it, for the
/// standard type the first byte picks; text that reads must write back as
/// YAML that reads to the same message.
pub fn message_text(data: &[u8]) {
    let Some((pick, text)) = data.split_first() else {
        return;
    };
    let (Some(ty), Ok(text)) = (standard_type(*pick), std::str::from_utf8(text)) else {
        return;
    };
    let Ok(message) = ty.message_from_yaml_at(text, (1, 2)) else {
        return;
    };
    let Ok(bytes) = to_vec(&message) else {
        // A value past a field's bound is read, and refused when encoded.
        return;
    };
    let yaml = message.to_yaml();
    let back = ty
        .message_from_yaml(&yaml)
        .unwrap_or_else(|e| panic!("{}: its YAML does not read back: {e}\n{yaml}", ty.name()));
    assert_eq!(to_vec(&back).ok(), Some(bytes), "{}\n{yaml}", ty.name());
}

/// Target `parameter_text`: a parameter file, a `-p name:=value` and a
/// value as `param set` reads it, from the same text.
pub fn parameter_text(data: &[u8]) {
    use shm_runtime::parameters::{ParameterOverrides, ParameterValue};
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let mut overrides = ParameterOverrides::default();
    if overrides.add_yaml_text(text).is_ok() {
        let _ = overrides.for_node("/ns/node");
    }
    let _ = ParameterValue::from_yaml_text(text);
    let args = ["prog", "--ros-args"]
        .into_iter()
        .chain(text.split_whitespace());
    if let Ok(overrides) = ParameterOverrides::from_ros_args(args) {
        let _ = overrides.for_node("/node");
    }
}

/// Target `liveliness_tokens`: lines read as liveliness tokens under
/// `@ros2_lv`; every query of the graph answers, and what it holds stays
/// within its bounds.
pub fn liveliness_tokens(data: &[u8]) {
    use shm_runtime::graph::{Graph, MAX_ENTITIES, MAX_UNREADABLE};
    let text = String::from_utf8_lossy(data);
    let graph = Graph::from_tokens(text.split('\n'));
    assert!(graph.len() <= MAX_ENTITIES && graph.unreadable().len() <= MAX_UNREADABLE);
    for e in graph.unreadable() {
        assert!(e.token.len() <= 260, "an unreadable token kept whole");
    }
    for node in graph.nodes() {
        let _ = graph.node_endpoints(&node);
    }
    for topic in graph.topics().into_keys() {
        let _ = (graph.publishers(&topic), graph.types_of(&topic));
    }
    let _ = graph.services();
}

/// Target `bag`: a bag directory from `data` (its `metadata.yaml`, then its
/// one MCAP file), opened, described and read through as `bag info` and
/// `bag play` read it; and the MCAP file alone.
pub fn bag(data: &[u8]) {
    let (metadata, mcap) = split(data);
    let dir = scratch_dir();
    let _ = std::fs::remove_dir_all(&dir);
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let write = |name: &str, bytes: &[u8]| {
        std::fs::File::create(dir.join(name)).and_then(|mut f| f.write_all(bytes))
    };
    if write(shm_bag::metadata::FILE_NAME, metadata).is_err() || write("bag_0.mcap", mcap).is_err()
    {
        return;
    }
    read_through(&dir);
    read_through(&dir.join("bag_0.mcap"));
    let _ = std::fs::remove_dir_all(&dir);
}

fn read_through(path: &std::path::Path) {
    let Ok(bag) = shm_bag::Bag::open(path) else {
        return;
    };
    let _ = bag.describe();
    let _ = bag.topics();
    let mut count = 0u64;
    let _ = bag.read_messages(
        0,
        |_| {},
        |_, _, data| {
            count += 1;
            std::hint::black_box(data);
            ControlFlow::<()>::Continue(())
        },
    );
}

/// A directory of this process and thread's own under the system's
/// temporary directory.
fn scratch_dir() -> std::path::PathBuf {
    std::env::temp_dir().join(format!(
        "shm-fuzz-bag-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ))
}
