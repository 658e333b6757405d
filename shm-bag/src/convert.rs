//! Converting recordings, as `ros2 bag convert` does: one or more bags of
//! any storage this crate reads (MCAP, sqlite3) into one MCAP bag, merged in
//! log-time order, with the chunk compression, chunk size and splitting
//! asked for, and a chosen set of topics.

use std::path::Path;

use regex::Regex;
use shm_runtime::rmw::Distro;

use crate::metadata::TopicMetadata;
use crate::storage::RecordedTopic;
use shm_runtime::types;

use crate::{qos, Bag, BagMetadata, BagWriter, Error, WriteOptions};

/// What to convert and how to write it.
#[derive(Debug, Clone, Default)]
pub struct ConvertOptions {
    /// How the new bag is written (compression, chunk size, splitting).
    pub write: WriteOptions,
    /// Only these topics (all when empty).
    pub topics: Vec<String>,
    /// Leave out the topics this matches.
    pub exclude: Option<Regex>,
    /// The distribution whose standard definitions stand in for a type whose
    /// definition the input does not keep (a sqlite3 bag before Iron);
    /// `None`: the input's `ros_distro`, else the default distribution.
    pub distro: Option<Distro>,
}

/// What a conversion wrote.
#[derive(Debug, Clone)]
pub struct Converted {
    /// The new bag's `metadata.yaml`.
    pub metadata: BagMetadata,
    /// Types the input keeps no definition of and that are not standard:
    /// their MCAP schemas are empty (readers that need one cannot decode
    /// them).
    pub without_definition: Vec<String>,
}

/// Write every selected message of `input` (a bag, or several
/// [merged](Bag::merge)) into the new bag directory `output`, in log-time
/// order, keeping each message's bytes, times and sequence number and each
/// topic's type, hash and QoS.
///
/// ```no_run
/// use shm_bag::{convert, Bag, Compression, ConvertOptions, WriteOptions};
///
/// // A Humble bag in sqlite3 storage, as zstd-compressed MCAP.
/// let options = ConvertOptions {
///     write: WriteOptions { compression: Some(Compression::Zstd), ..Default::default() },
///     ..Default::default()
/// };
/// let converted = convert(&Bag::open("humble_bag".as_ref())?, "as_mcap".as_ref(), &options)?;
/// println!("{} messages", converted.metadata.message_count);
/// # Ok::<(), shm_bag::Error>(())
/// ```
pub fn convert(input: &Bag, output: &Path, options: &ConvertOptions) -> Result<Converted, Error> {
    let topics = input.topics()?;
    for wanted in &options.topics {
        if !topics.iter().any(|t| &t.name == wanted) {
            let mut list: Vec<&str> = topics.iter().map(|t| t.name.as_str()).collect();
            list.dedup();
            return Err(format!(
                "the input has no topic {wanted}; it has {}",
                list.join(", ")
            )
            .into());
        }
    }
    let selected: Vec<&RecordedTopic> = topics
        .iter()
        .filter(|t| options.topics.is_empty() || options.topics.contains(&t.name))
        .filter(|t| {
            !options
                .exclude
                .as_ref()
                .is_some_and(|r| r.is_match(&t.name))
        })
        .collect();
    let distro = options
        .distro
        .or_else(|| {
            input
                .metadata()
                .and_then(|m| m.ros_distro.parse::<Distro>().ok())
        })
        .unwrap_or_default();
    let definitions = input.definitions()?;
    let mut without_definition = Vec::new();
    let mut writer = BagWriter::create(output, options.write.clone())?;
    let mut ids = std::collections::HashMap::new();
    for topic in selected {
        let definition = match definitions.get(&topic.type_name) {
            Some(definition) => definition.clone(),
            None => match types::standard_message(&topic.type_name, distro) {
                Some(standard) => standard.definition,
                None => {
                    if !without_definition.contains(&topic.type_name) {
                        without_definition.push(topic.type_name.clone());
                    }
                    String::new()
                }
            },
        };
        let metadata = TopicMetadata {
            name: topic.name.clone(),
            type_name: topic.type_name.clone(),
            serialization_format: topic.message_encoding.clone(),
            offered_qos_profiles: topic
                .offered_qos
                .iter()
                .map(qos::QosProfile::from)
                .collect(),
            type_description_hash: topic.type_hash.clone(),
        };
        let id = writer.add_topic(metadata, definition)?;
        ids.entry(topic.name.clone())
            .or_insert_with(Vec::new)
            .push((topic.type_name.clone(), id));
    }
    let mut failure = None;
    input.read(
        0,
        |_| {},
        |message| {
            // A topic may be recorded with several types: each its channel.
            let id = ids.get(message.topic).and_then(|by_type| {
                by_type
                    .iter()
                    .find(|(type_name, _)| type_name == message.type_name)
                    .map(|(_, id)| *id)
            });
            let Some(id) = id else {
                return std::ops::ControlFlow::Continue(());
            };
            match writer.write(
                id,
                message.log_time,
                message.publish_time,
                message.sequence,
                message.data,
            ) {
                Ok(()) => std::ops::ControlFlow::Continue(()),
                Err(e) => {
                    failure = Some(e);
                    std::ops::ControlFlow::Break(())
                }
            }
        },
    )?;
    if let Some(failure) = failure {
        // What was written stays a readable bag.
        let _ = writer.finish();
        return Err(failure);
    }
    let mut metadata = writer.finish()?;
    if let Some(old) = input.metadata() {
        if !old.ros_distro.is_empty() {
            metadata.ros_distro = old.ros_distro.clone();
            let path = output.join(crate::metadata::FILE_NAME);
            std::fs::write(&path, metadata.to_yaml())
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        }
    }
    Ok(Converted {
        metadata,
        without_definition,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::writer::tests::topic;
    use crate::Compression;

    #[test]
    fn a_bag_converts_to_compressed_split_mcap_with_every_message_and_time() {
        let base = std::env::temp_dir().join(format!("shm-bag-convert-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let input = base.join("in");
        let mut writer = BagWriter::create(&input, WriteOptions::default()).unwrap();
        let a = writer.add_topic(topic("/a"), "string data".into()).unwrap();
        let b = writer.add_topic(topic("/b"), "string data".into()).unwrap();
        let data = |i: u64| [0, 1, 0, 0, 2, 0, 0, 0, b'a' + (i % 26) as u8, 0];
        // Written out of time order.
        for i in (0..40u64).rev() {
            let topic = if i % 2 == 0 { a } else { b };
            writer
                .write(topic, 100 + i, 50 + i, i as u32, &data(i))
                .unwrap();
        }
        writer.finish().unwrap();
        let output = base.join("out");
        let options = ConvertOptions {
            write: WriteOptions {
                compression: Some(Compression::Zstd),
                max_bag_duration: Some(std::time::Duration::from_nanos(10)),
                ..Default::default()
            },
            exclude: Some(Regex::new("^/b$").unwrap()),
            ..Default::default()
        };
        let converted = convert(&Bag::open(&input).unwrap(), &output, &options).unwrap();
        assert!(converted.without_definition.is_empty());
        assert_eq!(converted.metadata.message_count, 20);
        assert!(converted.metadata.relative_file_paths.len() > 1);
        let out = Bag::open(&output).unwrap();
        let mut got = Vec::new();
        out.read(
            0,
            |_| {},
            |m| {
                got.push((
                    m.topic.to_owned(),
                    m.log_time,
                    m.publish_time,
                    m.sequence,
                    m.data.to_vec(),
                ));
                std::ops::ControlFlow::<()>::Continue(())
            },
        )
        .unwrap();
        let expected: Vec<_> = (0..40u64)
            .filter(|i| i % 2 == 0)
            .map(|i| ("/a".to_owned(), 100 + i, 50 + i, i as u32, data(i).to_vec()))
            .collect();
        assert_eq!(got, expected);
        assert_eq!(
            out.definitions().unwrap()["std_msgs/msg/String"],
            "string data"
        );
        // The output must not exist, as for rosbag2.
        let again = convert(&Bag::open(&input).unwrap(), &output, &options).unwrap_err();
        assert!(again.to_string().contains("exists already"), "{again}");
        let _ = std::fs::remove_dir_all(&base);
    }
}
