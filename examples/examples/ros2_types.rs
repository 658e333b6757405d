//! Every generated interface type, for `tests/ros2/check.py` (real ROS 2: rosidl's
//! `.json` type hashes and rclpy's serializer).
//!
//! ```text
//! ros2_types hashes      # one line per type: `<kind> <type name> <RIHS01 hash>`
//! ros2_types user-hashes # the same for examples/interfaces/robot_interfaces (build.rs)
//! ros2_types distro-hashes # `<distro> <type name> <hash>` of each standard message a
//!                         # distribution defines differently (shm_cdr::distro_msgs)
//! ros2_types descriptions # one JSON object per line: a type's full description
//!                         # (default values included) and its sources
//! ros2_types roundtrip   # stdin: `<type name> <hex>` lines; stdout: `ok <hex>` or `err <why>`
//! ros2_types rosidl-json # stdin: paths of rosidl's `.json` type descriptions; stdout: the
//!                        # run-time type's name and hash, or `err <why>`
//! ros2_types yaml        # stdin: `<type name> <options> <hex>` lines; stdout: the run-time
//!                        # typed message as YAML (a JSON string), that text read back and
//!                        # encoded (hex, or `-` if the options cut it short), its JSON
//! ```
//!
//! `yaml`'s options are `-` or comma-separated `t<N>` (truncate length),
//! `a` (no arrays), `s` (no strings), `f` (flow style): `ros2 topic echo`'s.
//!
//! `roundtrip` decodes the CDR bytes (as real ROS 2 sent them: stale padding,
//! bytes after the end) into the owned type, re-encodes them, and checks that the
//! size function is exact, that the borrowing `…Ref` form decodes to the same
//! bytes (and is the type's `BorrowedForm`), and that decoding into a kept value of
//! an earlier message gives them too, and that the run-time type built from
//! the type's description (`shm_cdr::dynamic`) decodes the input and encodes
//! the same bytes, with the same hash.

use std::collections::HashMap;
use std::io::{BufRead, Write};

use shm_cdr::{CdrEncode, DecodeOwned, RosAction, RosMessage, RosService};

type Roundtrip = fn(&[u8], &mut Vec<u8>) -> Result<Vec<u8>, String>;

fn owned<T: RosMessage + DecodeOwned + Default>(
    input: &[u8],
    _: &mut Vec<u8>,
) -> Result<Vec<u8>, String> {
    let value: T = shm_cdr::from_bytes(input).map_err(|e| e.to_string())?;
    let out = shm_cdr::to_vec(&value).map_err(|e| e.to_string())?;
    if out.len() != shm_cdr::encoded_size(&value) {
        return Err(format!(
            "encoded_size {} but {} bytes written",
            shm_cdr::encoded_size(&value),
            out.len()
        ));
    }
    // Into a kept value that held something else first: same result.
    let mut kept = T::default();
    shm_cdr::from_bytes_into(&out, &mut kept).map_err(|e| e.to_string())?;
    shm_cdr::from_bytes_into(input, &mut kept).map_err(|e| e.to_string())?;
    if shm_cdr::to_vec(&kept).map_err(|e| e.to_string())? != out {
        return Err("decode_into differs from decode".into());
    }
    dynamic::<T>(input, &out)?;
    Ok(out)
}

/// The same input read by the run-time type built from `T`'s description:
/// it must encode to the generated type's bytes, sized exactly, its hash
/// must be `T`'s, and a view of the input must read the same message.
fn dynamic<T: RosMessage>(input: &[u8], out: &[u8]) -> Result<(), String> {
    let ty = shm_cdr::dynamic::DynamicType::from_description(&T::full_description())
        .map_err(|e| format!("dynamic type: {e}"))?;
    if ty.type_hash() != T::type_hash() {
        return Err(format!(
            "dynamic type hash {} != {}",
            ty.type_hash(),
            T::type_hash()
        ));
    }
    let message = ty
        .decode(input)
        .map_err(|e| format!("dynamic decode: {e}"))?;
    let bytes = shm_cdr::to_vec(&message).map_err(|e| format!("dynamic encode: {e}"))?;
    if bytes != out {
        return Err("the dynamic message encodes differently".into());
    }
    if shm_cdr::encoded_size(&message) != bytes.len() {
        return Err(format!(
            "dynamic encoded_size {} but {} bytes written",
            shm_cdr::encoded_size(&message),
            bytes.len()
        ));
    }
    let viewed = ty
        .view(input)
        .and_then(|view| view.to_message())
        .map_err(|e| format!("dynamic view: {e}"))?;
    // Compared as bytes: NaN is not equal to itself.
    if shm_cdr::to_vec(&viewed).ok() != Some(bytes) {
        return Err("the dynamic view reads otherwise than the dynamic decoder".into());
    }
    Ok(())
}

/// [`owned`], then the borrowing form `R` must decode the input to the same bytes.
fn check_ref<R: CdrEncode>(
    view: Result<R, shm_cdr::DecodeError>,
    out: Vec<u8>,
) -> Result<Vec<u8>, String> {
    let view = view.map_err(|e| format!("Ref form: {e}"))?;
    if shm_cdr::to_vec(&view).map_err(|e| e.to_string())? != out {
        return Err("the Ref form encodes differently".into());
    }
    Ok(out)
}

macro_rules! tables {
    (messages: [$($m:path,)*], borrowed: [$(($o:path, $r:path),)*], services: [$($s:path,)*], actions: [$($a:path,)*],) => {
        fn hashes() -> Vec<(&'static str, &'static str, &'static str)> {
            vec![
                $( ("message", <$m as RosMessage>::TYPE_NAME, <$m as RosMessage>::type_hash()), )*
                $( ("service", <$s as RosService>::TYPE_NAME, <$s as RosService>::type_hash()), )*
                $( ("action", <$a as RosAction>::TYPE_NAME, <$a as RosAction>::type_hash()), )*
            ]
        }

        fn descriptions() -> Vec<shm_cdr::describe::FullDescription> {
            vec![
                $( <$m as RosMessage>::full_description(), )*
                $( <$s as RosService>::full_description(), )*
                $( <$a as RosAction>::full_description(), )*
            ]
        }

        fn roundtrips() -> HashMap<&'static str, Roundtrip> {
            let mut out: HashMap<&'static str, Roundtrip> = HashMap::new();
            $( out.insert(<$m as RosMessage>::TYPE_NAME, owned::<$m>); )*
            $({
                fn with_ref(input: &[u8], scratch: &mut Vec<u8>) -> Result<Vec<u8>, String> {
                    let out = owned::<$o>(input, scratch)?;
                    let view: Result<$r, _> = shm_cdr::from_bytes(input);
                    // Compiles only if `$r` is the type's `BorrowedForm`.
                    let view = view.map(|v| -> <$o as shm_cdr::BorrowedForm>::Ref<'_> { v });
                    check_ref(view, out)
                }
                out.insert(<$o as RosMessage>::TYPE_NAME, with_ref);
            })*
            out
        }
    };
}

shm_cdr::for_each_interface!(tables);

fn main() {
    let mode = std::env::args().nth(1).unwrap_or_default();
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    match mode.as_str() {
        "hashes" => {
            for (kind, name, hash) in hashes() {
                let _ = writeln!(out, "{kind} {name} {hash}");
            }
        }
        "distro-hashes" => {
            // The standard messages a distribution defines differently.
            for variant in shm_cdr::distro_msgs::variants() {
                for distro in variant.distros {
                    let _ = writeln!(out, "{distro} {} {}", variant.type_name, variant.type_hash);
                }
            }
        }
        "user-hashes" => {
            use shm_cdr_examples::generated::robot_interfaces::{action, msg, srv};
            let types = [
                (
                    "message",
                    msg::Battery::TYPE_NAME,
                    msg::Battery::type_hash(),
                ),
                (
                    "message",
                    msg::CellHistory::TYPE_NAME,
                    msg::CellHistory::type_hash(),
                ),
                (
                    "message",
                    srv::SetSpeed_Event::TYPE_NAME,
                    srv::SetSpeed_Event::type_hash(),
                ),
                (
                    "service",
                    srv::SetSpeed::TYPE_NAME,
                    srv::SetSpeed::type_hash(),
                ),
                (
                    "message",
                    action::Dock_FeedbackMessage::TYPE_NAME,
                    action::Dock_FeedbackMessage::type_hash(),
                ),
                (
                    "service",
                    action::Dock_SendGoal::TYPE_NAME,
                    action::Dock_SendGoal::type_hash(),
                ),
                ("action", action::Dock::TYPE_NAME, action::Dock::type_hash()),
            ];
            for (kind, name, hash) in types {
                let _ = writeln!(out, "{kind} {name} {hash}");
            }
        }
        "descriptions" => {
            for description in descriptions() {
                let sources: Vec<serde_json::Value> = description
                    .sources()
                    .map(|(type_name, encoding, text)| {
                        serde_json::json!({
                            "type_name": type_name,
                            "encoding": encoding,
                            "raw_file_contents": text,
                        })
                    })
                    .collect();
                let line = serde_json::json!({
                    "type_description_msg": serde_json::from_str::<serde_json::Value>(&description.json())
                        .unwrap_or_else(|e| panic!("{}: not JSON: {e}", description.own.type_name)),
                    "sources": sources,
                });
                let _ = writeln!(out, "{line}");
            }
        }
        "roundtrip" => {
            let table = roundtrips();
            let mut scratch = Vec::new();
            for line in std::io::stdin().lock().lines() {
                let Ok(line) = line else { break };
                let reply = match line.split_once(' ') {
                    Some((name, hex)) => match (table.get(name), decode_hex(hex.trim())) {
                        (Some(f), Some(bytes)) => match f(&bytes, &mut scratch) {
                            Ok(bytes) => format!("ok {}", encode_hex(&bytes)),
                            Err(e) => format!("err {e}"),
                        },
                        (None, _) => format!("err unknown type {name}"),
                        (_, None) => "err bad hex".to_owned(),
                    },
                    None => "err expected `<type> <hex>`".to_owned(),
                };
                let _ = writeln!(out, "{reply}");
                let _ = out.flush();
            }
        }
        "rosidl-json" => {
            for line in std::io::stdin().lock().lines() {
                let Ok(path) = line else { break };
                let reply = std::fs::read_to_string(path.trim())
                    .map_err(|e| e.to_string())
                    .and_then(|text| {
                        shm_cdr::dynamic::DynamicType::from_rosidl_json(&text)
                            .map_err(|e| e.to_string())
                    })
                    .map_or_else(
                        |e| format!("err {e}"),
                        |ty| format!("{} {}", ty.name(), ty.type_hash()),
                    );
                let _ = writeln!(out, "{reply}");
                let _ = out.flush();
            }
        }
        "yaml" => {
            let types: HashMap<String, shm_cdr::dynamic::DynamicType> = descriptions()
                .iter()
                .filter_map(|d| {
                    let ty = shm_cdr::dynamic::DynamicType::from_description(d).ok()?;
                    Some((ty.name().to_owned(), ty))
                })
                .collect();
            for line in std::io::stdin().lock().lines() {
                let Ok(line) = line else { break };
                let reply = yaml_reply(&types, &line).unwrap_or_else(|e| format!("err {e}"));
                let _ = writeln!(out, "{reply}");
                let _ = out.flush();
            }
        }
        _ => {
            eprintln!("usage: ros2_types hashes | user-hashes | descriptions | roundtrip | rosidl-json | yaml");
            std::process::exit(2);
        }
    }
}

/// `yaml` mode: the message as YAML with the options given, and, when nothing
/// was cut or abbreviated, that text read back and encoded, and the message
/// as JSON.
fn yaml_reply(
    types: &HashMap<String, shm_cdr::dynamic::DynamicType>,
    line: &str,
) -> Result<String, String> {
    let mut parts = line.splitn(3, ' ');
    let (Some(name), Some(flags), Some(hex)) = (parts.next(), parts.next(), parts.next()) else {
        return Err("expected `<type> <options> <hex>`".into());
    };
    let ty = types
        .get(name)
        .ok_or_else(|| format!("unknown type {name}"))?;
    let bytes = decode_hex(hex.trim()).ok_or("bad hex")?;
    let message = ty.decode(&bytes).map_err(|e| e.to_string())?;
    let mut options = shm_cdr::dynamic::YamlOptions::full();
    for flag in flags.split(',').filter(|f| *f != "-") {
        options = match flag {
            "a" => options.no_arr(true),
            "s" => options.no_str(true),
            "f" => options.flow_style(true),
            t => options.truncate_length(Some(
                t.strip_prefix('t')
                    .and_then(|n| n.parse().ok())
                    .ok_or_else(|| format!("bad option {t}"))?,
            )),
        };
    }
    let text = message.to_yaml_with(&options);
    let lossless = options.truncate_length.is_none() && !options.no_arr && !options.no_str;
    let back = if lossless {
        let read = ty
            .message_from_yaml(&text)
            .map_err(|e| format!("our YAML does not read back: {e}"))?;
        encode_hex(&shm_cdr::to_vec(&read).map_err(|e| e.to_string())?)
    } else {
        "-".to_owned()
    };
    let json = serde_json::to_string(&message).map_err(|e| e.to_string())?;
    Ok(format!(
        "ok {} {back} {json}",
        serde_json::Value::String(text)
    ))
}

fn decode_hex(s: &str) -> Option<Vec<u8>> {
    (0..s.len())
        .step_by(2)
        .map(|i| s.get(i..i + 2).and_then(|b| u8::from_str_radix(b, 16).ok()))
        .collect()
}

fn encode_hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
