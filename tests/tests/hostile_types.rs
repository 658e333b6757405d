//! Type descriptions as a hostile node would send them (a node's
//! `~/get_type_description` answers with whatever it likes, and announces
//! the hash of its own description): each is refused with an error naming
//! the limit, or built and used within bounds. Every case runs in a child
//! process of this test binary whose address space is capped at 512 MiB, on
//! a thread with a 2 MiB stack, so an abort, a stack overflow or a runaway
//! allocation fails the test instead of passing by luck.

use std::process::Command;
use std::time::Instant;

use shm_cdr::dynamic::{DynamicType, TypeError, TypeLimits, Value};
use shm_cdr::msgs::type_description_interfaces::msg::{
    Field, FieldType, IndividualTypeDescription, TypeDescription,
};
use shm_cdr::BoundedString;

const CHILD: &str = "SHM_CDR_HOSTILE_CASE";
const MEMORY: u64 = 512 << 20;
const STACK: usize = 2 << 20;

/// Run `case` in a child process of this binary under [`MEMORY`], on a
/// thread of [`STACK`]; fail if the child does not exit cleanly.
fn bounded(name: &str, case: fn()) {
    if std::env::var(CHILD).as_deref() == Ok(name) {
        rlimit::setrlimit(rlimit::Resource::AS, MEMORY, MEMORY).expect("cap the address space");
        let worker = std::thread::Builder::new()
            .stack_size(STACK)
            .spawn(case)
            .expect("spawn the case's thread");
        if worker.join().is_err() {
            std::process::exit(3);
        }
        return;
    }
    let exe = std::env::current_exe().expect("this test binary");
    let output = Command::new(exe)
        .args([name, "--exact", "--nocapture", "--test-threads=1"])
        .env(CHILD, name)
        .output()
        .expect("run the case in a child process");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success() && stdout.contains("1 passed"),
        "{name} did not finish cleanly under {MEMORY} bytes and a {STACK}-byte stack \
         ({}):\n{stdout}\n{stderr}",
        output.status
    );
}

fn field(name: &str, type_id: u8, capacity: u64, nested: &str) -> Field {
    Field {
        name: name.into(),
        r#type: FieldType {
            type_id,
            capacity,
            string_capacity: 0,
            nested_type_name: bounded_name(nested),
        },
        default_value: String::new(),
    }
}

fn bounded_name(name: &str) -> BoundedString<255> {
    BoundedString::from(name.to_owned())
}

fn described(name: &str, fields: Vec<Field>) -> IndividualTypeDescription {
    IndividualTypeDescription {
        type_name: bounded_name(name),
        fields,
    }
}

const NESTED: u8 = 1;
const UINT8: u8 = 3;
const FLOAT64: u8 = 11;
const ARRAY: u8 = 48;

fn level(i: usize) -> String {
    format!("hostile_msgs/msg/L{i}")
}

/// `depth` types, each a byte and the next type; the last only a byte.
fn chain(depth: usize) -> TypeDescription {
    let mut types: Vec<_> = (0..depth)
        .map(|i| {
            let mut fields = vec![field("x", UINT8, 0, "")];
            if i + 1 < depth {
                fields.push(field("next", NESTED, 0, &level(i + 1)));
            }
            described(&level(i), fields)
        })
        .collect();
    let root = types.remove(0);
    TypeDescription {
        type_description: root,
        referenced_type_descriptions: types,
    }
}

/// `depth` types of `width` fields, each field nesting the next type.
fn fan_out(depth: usize, width: usize) -> TypeDescription {
    let mut types: Vec<_> = (0..depth)
        .map(|i| {
            let fields = (0..width)
                .map(|k| {
                    if i + 1 < depth {
                        field(&format!("f{k}"), NESTED, 0, &level(i + 1))
                    } else {
                        field(&format!("f{k}"), UINT8, 0, "")
                    }
                })
                .collect();
            described(&level(i), fields)
        })
        .collect();
    let root = types.remove(0);
    TypeDescription {
        type_description: root,
        referenced_type_descriptions: types,
    }
}

fn refused(description: &TypeDescription) -> TypeError {
    let start = Instant::now();
    let error = DynamicType::from_type_description_msg(description)
        .expect_err("a description past the limits is refused");
    println!("refused in {:?}: {error}", start.elapsed());
    // An error quotes names cut short, whatever their length.
    assert!(error.to_string().len() < 600, "{error}");
    error
}

/// Every walk over a message of `ty`: default, encode, decode, view, YAML
/// out and back in.
fn every_walk(ty: &DynamicType) {
    let message = ty.default_message();
    let bytes = shm_cdr::to_vec(&message).expect("encode the default");
    let decoded = ty.decode(&bytes).expect("decode");
    assert_eq!(decoded, message);
    let view = ty.view(&bytes).expect("view");
    assert_eq!(view.to_message().expect("view to message"), message);
    let yaml = message.to_yaml();
    // Output linear in the message: indentation included.
    assert!(
        yaml.len() < 64 * bytes.len() + 4096,
        "{} bytes of YAML",
        yaml.len()
    );
    assert_eq!(ty.message_from_yaml(&yaml).expect("YAML back"), message);
    assert!(ty.type_hash().starts_with("RIHS01_"));
}

#[test]
fn a_chain_past_the_depth_limit_is_refused() {
    bounded("a_chain_past_the_depth_limit_is_refused", || {
        // Past the other limits too, the depth is what is refused.
        let mut limits = TypeLimits::default();
        limits.max_types = usize::MAX;
        limits.max_fields = usize::MAX;
        for depth in [TypeLimits::DEFAULT.max_depth + 1, 10_000, 100_000] {
            let description = chain(depth);
            refused(&description);
            let error = DynamicType::from_type_description_msg_with(&description, &limits)
                .expect_err("refused");
            assert!(error.reason.contains("max_depth"), "{error}");
            assert_eq!(error.field.as_deref(), Some("next"), "{error}");
        }
    });
}

#[test]
fn a_chain_at_the_depth_limit_is_walked_on_a_small_stack() {
    bounded(
        "a_chain_at_the_depth_limit_is_walked_on_a_small_stack",
        || {
            let ty = DynamicType::from_type_description_msg(&chain(TypeLimits::DEFAULT.max_depth))
                .expect("a chain at the limit is built");
            every_walk(&ty);
        },
    );
}

#[test]
fn a_fan_out_whose_messages_hold_too_many_fields_is_refused() {
    bounded(
        "a_fan_out_whose_messages_hold_too_many_fields_is_refused",
        || {
            for (depth, width) in [(10, 10), (4, 100), (20, 2)] {
                let error = refused(&fan_out(depth, width));
                assert!(error.reason.contains("max_message_fields"), "{error}");
            }
        },
    );
}

#[test]
fn a_fan_out_within_the_limits_takes_memory_linear_in_its_description() {
    bounded(
        "a_fan_out_within_the_limits_takes_memory_linear_in_its_description",
        || {
            // 3 levels of 30: a message holds 27 930 fields, its type 90.
            let ty = DynamicType::from_type_description_msg(&fan_out(3, 30)).expect("built");
            every_walk(&ty);
            // 15 levels of 2: 65 534 fields per message, at the limit.
            let ty = DynamicType::from_type_description_msg(&fan_out(15, 2)).expect("built");
            every_walk(&ty);
        },
    );
}

#[test]
fn too_many_fields_or_types_are_refused() {
    bounded("too_many_fields_or_types_are_refused", || {
        let fields = (0..100_000)
            .map(|k| field(&format!("f{k}"), UINT8, 0, ""))
            .collect();
        let wide = TypeDescription {
            type_description: described("hostile_msgs/msg/Wide", fields),
            referenced_type_descriptions: Vec::new(),
        };
        assert!(refused(&wide).reason.contains("max_fields"));

        let many = TypeDescription {
            type_description: described("hostile_msgs/msg/Root", vec![field("x", UINT8, 0, "")]),
            referenced_type_descriptions: (0..100_000)
                .map(|i| described(&level(i), vec![field("x", UINT8, 0, "")]))
                .collect(),
        };
        assert!(refused(&many).reason.contains("max_types"));
    });
}

#[test]
fn long_names_and_defaults_are_refused_and_quoted_short() {
    bounded(
        "long_names_and_defaults_are_refused_and_quoted_short",
        || {
            let name = "n".repeat(1 << 20);
            let long_field = TypeDescription {
                type_description: described(
                    "hostile_msgs/msg/Long",
                    vec![field(&name, UINT8, 0, "")],
                ),
                referenced_type_descriptions: Vec::new(),
            };
            let error = refused(&long_field);
            assert!(error.reason.contains("max_name_len"), "{error}");
            assert!(error
                .field
                .as_deref()
                .unwrap_or("")
                .contains("1048576 bytes"));

            let mut default = field("x", UINT8, 0, "");
            default.default_value = "1".repeat(1 << 20);
            let long_default = TypeDescription {
                type_description: described("hostile_msgs/msg/Long", vec![default]),
                referenced_type_descriptions: Vec::new(),
            };
            assert!(refused(&long_default).reason.contains("max_default_len"));
        },
    );
}

#[test]
fn arrays_no_message_could_carry_are_refused_when_the_type_is_built() {
    bounded(
        "arrays_no_message_could_carry_are_refused_when_the_type_is_built",
        || {
            let bytes = TypeDescription {
                type_description: described(
                    "hostile_msgs/msg/Huge",
                    vec![field("data", ARRAY + UINT8, u64::from(u32::MAX), "")],
                ),
                referenced_type_descriptions: Vec::new(),
            };
            let error = refused(&bytes);
            assert!(error.reason.contains("max_default_size"), "{error}");
            assert_eq!(error.field.as_deref(), Some("data"));

            let big = described(
                "hostile_msgs/msg/Big",
                (0..1000)
                    .map(|k| field(&format!("v{k}"), FLOAT64, 0, ""))
                    .collect(),
            );
            let bigs = TypeDescription {
                type_description: described(
                    "hostile_msgs/msg/Huge",
                    vec![field(
                        "items",
                        ARRAY + NESTED,
                        u64::from(u32::MAX),
                        "hostile_msgs/msg/Big",
                    )],
                ),
                referenced_type_descriptions: vec![big.clone()],
            };
            assert!(refused(&bigs).reason.contains("max_default_size"));

            // So many elements as fit within the limit: built, and its
            // default made, within the memory cap.
            let within = TypeDescription {
                type_description: described(
                    "hostile_msgs/msg/Large",
                    vec![field("items", ARRAY + NESTED, 1000, "hostile_msgs/msg/Big")],
                ),
                referenced_type_descriptions: vec![big],
            };
            let ty = DynamicType::from_type_description_msg(&within).expect("built");
            let message = ty.default_message();
            let Some(Value::Messages(items)) = message.value("items") else {
                panic!("no items");
            };
            assert_eq!(items.len(), 1000);
        },
    );
}

#[test]
fn a_field_named_twice_is_refused() {
    let twice = TypeDescription {
        type_description: described(
            "hostile_msgs/msg/Twice",
            vec![field("x", UINT8, 0, ""), field("x", FLOAT64, 0, "")],
        ),
        referenced_type_descriptions: Vec::new(),
    };
    let error = refused(&twice);
    assert_eq!(error.field.as_deref(), Some("x"));
    assert!(error.reason.contains("second field"), "{error}");
}

#[test]
fn limits_are_the_callers_to_set() {
    let description = chain(40);
    assert!(DynamicType::from_type_description_msg(&description).is_err());
    let mut limits = TypeLimits::default();
    limits.max_depth = 40;
    let ty = DynamicType::from_type_description_msg_with(&description, &limits).expect("built");
    assert_eq!(ty.structs().len(), 40);
}

#[test]
fn message_text_nested_past_any_type_is_refused_before_it_is_parsed() {
    bounded(
        "message_text_nested_past_any_type_is_refused_before_it_is_parsed",
        || {
            let ty = DynamicType::from_type_description_msg(&chain(3)).expect("built");
            for open in ["[", "{a: ", "- ["] {
                let text = format!("x: {}", open.repeat(100_000));
                let error = ty.message_from_yaml(&text).expect_err("refused");
                assert!(error.reason.contains("nest more than 128"), "{error}");
            }
            // An alias bomb: refused by the YAML reader.
            let mut bomb = String::from("a: &a [x, x]\n");
            for i in 0..30 {
                bomb += &format!("b{i}: &b{i} [*{}, *{}]\n", prev(i), prev(i));
            }
            fn prev(i: usize) -> String {
                if i == 0 {
                    "a".into()
                } else {
                    format!("b{}", i - 1)
                }
            }
            assert!(ty.message_from_yaml(&bomb).is_err());
        },
    );
}

#[test]
fn a_large_message_is_written_as_yaml_in_memory_linear_in_it() {
    bounded(
        "a_large_message_is_written_as_yaml_in_memory_linear_in_it",
        || {
            // 16 MiB of bytes: 64 MiB of YAML, one line per byte.
            let description = TypeDescription {
                type_description: described(
                    "hostile_msgs/msg/Bytes",
                    vec![field("data", ARRAY + UINT8, 16 << 20, "")],
                ),
                referenced_type_descriptions: Vec::new(),
            };
            let ty = DynamicType::from_type_description_msg(&description).expect("built");
            let message = ty.default_message();
            let yaml = message.to_yaml();
            assert_eq!(yaml.len(), "data:\n".len() + 4 * (16 << 20));
            // Text that long is not read back.
            let error = ty.message_from_yaml(&yaml).expect_err("refused");
            assert!(error.reason.contains("bytes long"), "{error}");
        },
    );
}
