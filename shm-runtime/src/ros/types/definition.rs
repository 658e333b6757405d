//! Complete message definitions in rosbag2's `ros2msg` form: the type's
//! `.msg` text first, then each type it uses after a line of 80 `=` and a
//! line `MSG: pkg/msg/Name`. This is what rosbag2 keeps in an MCAP schema
//! and what the `mcap` and `rosbags` readers decode with.

use shm_cdr::describe::FullDescription;
use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::type_description_interfaces::msg::{TypeDescription, TypeSource};

/// The line between definitions.
pub const DELIMITER: &str =
    "================================================================================";

/// The MCAP schema encoding of these texts.
pub const ENCODING: &str = "ros2msg";

/// The definition of a compiled type: the `.msg` files it was generated
/// from, where it has them, else text written back from its fields.
pub fn of_description(description: &FullDescription) -> String {
    join(
        description
            .sources()
            .map(|(name, _, text)| (name.to_owned(), text.into_owned())),
    )
}

/// The most bytes of one type's source text taken from a type-description
/// service; a longer one (no `.msg` file of ROS 2 comes near it) is replaced
/// by text written back from the description, so that a node cannot fill a
/// recording with text.
pub const MAX_SOURCE_TEXT: usize = 64 * 1024;

/// The definition of a type a type-description service described: the
/// `.msg` sources it sent where it sent them (`include_type_sources`) and
/// they are at most [`MAX_SOURCE_TEXT`] bytes, else text written back from
/// the description.
pub fn of_reply(description: &TypeDescription, sources: &[TypeSource]) -> String {
    match DynamicType::from_type_description_msg(description) {
        Ok(ty) => of_dynamic(&ty, |name| {
            sources
                .iter()
                .find(|s| s.type_name == name && s.encoding == "msg")
                .filter(|s| s.raw_file_contents.len() <= MAX_SOURCE_TEXT)
                .map(|s| s.raw_file_contents.clone())
        }),
        Err(_) => String::new(),
    }
}

/// The definition of a run-time type, each text taken from `source` where it
/// has one, else written back from the type's fields.
pub fn of_dynamic(ty: &DynamicType, source: impl Fn(&str) -> Option<String>) -> String {
    join(
        ty.msg_texts()
            .into_iter()
            .map(|(name, written)| (name.to_owned(), source(name).unwrap_or(written))),
    )
}

/// The texts of a definition, `(name, text)`: `type_name`'s first, then each
/// type after its `MSG:` line, named as that line names it (`pkg/msg/Name`,
/// or `pkg/Name` as ROS 1 wrote it).
pub fn split<'a>(type_name: &'a str, definition: &'a str) -> Vec<(&'a str, &'a str)> {
    let mut out = Vec::new();
    let mut name = type_name;
    let mut rest = definition;
    loop {
        // A delimiter is a whole line, followed by the next type's `MSG:` line.
        let next = rest.match_indices(DELIMITER).find_map(|(at, _)| {
            let line_start = at == 0 || rest[..at].ends_with('\n');
            let after = rest[at + DELIMITER.len()..].strip_prefix('\n')?;
            let header = after.strip_prefix("MSG: ")?;
            let end = header.find('\n').unwrap_or(header.len());
            let next_name = header[..end].trim();
            let body = header.get(end + 1..).unwrap_or("");
            line_start.then_some((at, next_name, body))
        });
        match next {
            Some((at, next_name, body)) => {
                out.push((name, rest[..at].trim_end_matches('\n')));
                name = next_name;
                rest = body;
            }
            None => {
                out.push((name, rest.trim_end_matches('\n')));
                return out;
            }
        }
    }
}

fn join(texts: impl Iterator<Item = (String, String)>) -> String {
    let mut out = String::new();
    for (i, (name, text)) in texts.enumerate() {
        if i > 0 {
            if !out.ends_with('\n') {
                out.push('\n');
            }
            out.push_str(DELIMITER);
            out.push_str("\nMSG: ");
            out.push_str(&name);
            out.push('\n');
        }
        out.push_str(&text);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_cdr::msgs::geometry_msgs::msg::PoseStamped;
    use shm_cdr::RosMessage;

    #[test]
    fn a_definition_lists_every_used_type_once_after_the_delimiter() {
        let text = of_description(&PoseStamped::full_description());
        let headers: Vec<&str> = text.lines().filter(|l| l.starts_with("MSG: ")).collect();
        assert_eq!(
            headers,
            [
                "MSG: builtin_interfaces/msg/Time",
                "MSG: geometry_msgs/msg/Point",
                "MSG: geometry_msgs/msg/Pose",
                "MSG: geometry_msgs/msg/Quaternion",
                "MSG: std_msgs/msg/Header",
            ]
        );
        assert!(text.contains("Pose pose"), "{text}");
        assert_eq!(text.matches(DELIMITER).count(), 5);
    }

    #[test]
    fn a_definition_splits_into_the_texts_it_joined() {
        let description = PoseStamped::full_description();
        let text = of_description(&description);
        let parts = split(PoseStamped::TYPE_NAME, &text);
        let sources: Vec<(String, String)> = description
            .sources()
            .map(|(name, _, text)| (name.to_owned(), text.trim_end_matches('\n').to_owned()))
            .collect();
        let parts: Vec<(String, String)> = parts
            .into_iter()
            .map(|(n, t)| (n.to_owned(), t.to_owned()))
            .collect();
        assert_eq!(parts, sources);
        // A delimiter inside a line, or without a `MSG:` line, is text.
        let odd = format!("string a # {DELIMITER}\n{DELIMITER}\nint32 b");
        assert_eq!(split("p/msg/A", &odd), [("p/msg/A", odd.as_str())]);
        assert_eq!(split("p/msg/A", ""), [("p/msg/A", "")]);
    }

    #[test]
    fn a_run_time_type_without_sources_writes_its_fields_back() {
        let ty = DynamicType::from_description(&PoseStamped::full_description()).unwrap();
        let text = of_dynamic(&ty, |_| None);
        assert!(
            text.starts_with("std_msgs/Header header\ngeometry_msgs/Pose pose\n"),
            "{text}"
        );
        assert!(
            text.contains("MSG: geometry_msgs/msg/Quaternion\nfloat64 x 0.0\n"),
            "{text}"
        );
    }
}
