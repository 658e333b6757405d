//! Replays the committed cargo-fuzz corpus (`fuzz/corpus/<target>/*`) through the
//! same code the fuzz targets run, so a plain `cargo test` exercises it.

use std::path::Path;

fn replay(target: &str, run: fn(&[u8])) -> usize {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz/corpus")
        .join(target);
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        let outcome = std::panic::catch_unwind(|| run(&data));
        assert!(outcome.is_ok(), "corpus input {} fails", path.display());
        count += 1;
    }
    count
}

#[test]
fn decode_corpus() {
    let n = replay("decode", shm_cdr_tests::fuzzing::decode);
    assert!(n >= 10, "only {n} decode corpus inputs");
}

#[test]
fn roundtrip_corpus() {
    let n = replay("roundtrip", shm_cdr_tests::fuzzing::roundtrip);
    assert!(n >= 10, "only {n} roundtrip corpus inputs");
}

#[test]
fn roundtrip_generated_corpus() {
    let n = replay(
        "roundtrip_generated",
        shm_cdr_tests::fuzzing::roundtrip_generated,
    );
    assert!(n >= 272, "only {n} roundtrip_generated corpus inputs");
}

#[test]
fn generated_types_over_the_other_corpora() {
    // The other targets' inputs are arbitrary bytes too.
    let n = replay("roundtrip", shm_cdr_tests::fuzzing::roundtrip_generated)
        + replay("decode", shm_cdr_tests::fuzzing::roundtrip_generated);
    assert!(n >= 20, "only {n} corpus inputs");
}

#[test]
fn type_description_corpus() {
    let n = replay("type_description", shm_cdr_tests::fuzzing::type_description);
    assert!(n >= 100, "only {n} type_description corpus inputs");
}

#[test]
fn message_text_corpus() {
    let n = replay("message_text", shm_cdr_tests::fuzzing::message_text);
    assert!(n >= 100, "only {n} message_text corpus inputs");
}

#[test]
fn parameter_text_corpus() {
    let n = replay("parameter_text", shm_cdr_tests::fuzzing::parameter_text);
    assert!(n >= 3, "only {n} parameter_text corpus inputs");
}

#[test]
fn liveliness_tokens_corpus() {
    let n = replay(
        "liveliness_tokens",
        shm_cdr_tests::fuzzing::liveliness_tokens,
    );
    assert!(n >= 1, "only {n} liveliness_tokens corpus inputs");
}

#[test]
fn bag_corpus() {
    let n = replay("bag", shm_cdr_tests::fuzzing::bag);
    assert!(n >= 2, "only {n} bag corpus inputs");
}

/// The seeds of the targets that read outside input, from real inputs: the
/// standard set's descriptions (as a node's `~/get_type_description` answers)
/// with their default payloads, their default messages as `topic pub` text,
/// parameter files, rmw_zenoh_cpp's liveliness tokens, and recordings this
/// project writes. Run with `--ignored` to write them again.
#[test]
#[ignore = "writes the seed corpora under fuzz/corpus"]
fn write_seed_corpora() {
    use shm_cdr::dynamic::DynamicType;
    use shm_cdr_tests::fuzzing::join;
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus");
    let write = |target: &str, name: &str, bytes: &[u8]| {
        let dir = corpus.join(target);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(format!("seed-{name}")), bytes).unwrap();
    };
    let table = shm_bag::types::standard();
    for (i, (name, known)) in table.iter().enumerate() {
        let description = (known.describe)();
        let Ok(ty) = DynamicType::from_description(&description) else {
            continue;
        };
        let file = name.replace('/', "-");
        let payload = shm_cdr::to_vec(&ty.default_message()).unwrap();
        let described = shm_cdr::to_vec(
            &shm_cdr::msgs::type_description_interfaces::msg::TypeDescription::from(&description),
        )
        .unwrap();
        write("type_description", &file, &join(&described, &payload));
        if let Ok(pick) = u8::try_from(i) {
            let mut text = vec![pick];
            text.extend_from_slice(ty.default_message().to_yaml().as_bytes());
            write("message_text", &file, &text);
        }
    }
    let parameters = [
        (
            "file",
            "/**:\n  ros__parameters:\n    use_sim_time: false\n    rate: 10.5\n    names: [a, b]\n\
             /robot/driver:\n  ros__parameters:\n    limits:\n      max_speed: 1.5\n      ids: [1, 2, 3]\n      on: [true, false]\n",
        ),
        ("value", "[1.0, 2.5, -3e4]"),
        ("args", "-p speed:=1.5 -p name:='robot one' --params-file /dev/null -p ids:=[1,2]"),
    ];
    for (name, text) in parameters {
        write("parameter_text", name, text.as_bytes());
    }
    let tokens = [
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/0/NN/%/%/talker",
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,",
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/11/SS/%/%ns/talker/%ns%talker%get_type_description/type_description_interfaces::srv::dds_::GetTypeDescription_/RIHS01_69b6f8f5b9bd2b5b4d1b1cc8e4b7c5b9d8c1b6b5f1e8d5a8d7b4c2e1f0a9b8c7/1:1:1,1:,:,:,,",
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/12/MS/%/%/talker/%image/sensor_msgs::msg::dds_::Image_/RIHS01_00/::,10:,:,:,,/backends:cpu:;cuda:device%3A0",
    ];
    write("liveliness_tokens", "graph", tokens.join("\n").as_bytes());
    for (name, compression) in [("plain", None), ("zstd", Some(shm_bag::Compression::Zstd))] {
        let dir = std::env::temp_dir().join(format!("shm-seed-bag-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let options = shm_bag::WriteOptions {
            compression,
            chunk_size: 256,
            ..Default::default()
        };
        let mut writer = shm_bag::BagWriter::create(&dir, options).unwrap();
        use shm_cdr::msgs::std_msgs::String as RosString;
        use shm_cdr::RosMessage;
        let topic = writer
            .add_topic(
                shm_bag::metadata::TopicMetadata {
                    name: "/chatter".into(),
                    type_name: RosString::TYPE_NAME.into(),
                    serialization_format: "cdr".into(),
                    offered_qos_profiles: Vec::new(),
                    type_description_hash: RosString::type_hash().into(),
                },
                shm_bag::definition::of_description(&RosString::full_description()),
            )
            .unwrap();
        for i in 0..5u32 {
            let bytes = shm_cdr::to_vec(&RosString {
                data: format!("hello {i}"),
            })
            .unwrap();
            writer
                .write(topic, u64::from(i) * 1000, u64::from(i) * 1000, i, &bytes)
                .unwrap();
        }
        let metadata = writer.finish().unwrap();
        let yaml = std::fs::read(dir.join(shm_bag::metadata::FILE_NAME)).unwrap();
        let mcap = std::fs::read(dir.join(&metadata.relative_file_paths[0])).unwrap();
        write("bag", name, &join(&yaml, &mcap));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
