//! ROS 2 names as rcl resolves and validates them: node names, namespaces, topic
//! names (absolute, relative to the namespace, private `~`, `{node}` / `{ns}`
//! substitutions), remapping rules (`--ros-args -r from:=to`) and
//! `ROS_DOMAIN_ID`. A bad name is an error that says which rule it breaks,
//! before Zenoh ever sees it.

use std::fmt;

mod remap;

pub use remap::{ros_args_remaps, NameKind, RemapRule, RemapTarget, Remaps};

/// A name (or domain id) that ROS 2 would refuse.
#[derive(Clone, PartialEq, Eq)]
pub struct NameError {
    /// What was being named: `node name`, `namespace`, `topic name`,
    /// `ROS_DOMAIN_ID`.
    pub what: &'static str,
    /// The name as given.
    pub name: String,
    /// The rule it breaks.
    pub reason: String,
}

impl fmt::Display for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid {} {:?}: {}", self.what, self.name, self.reason)
    }
}

impl fmt::Debug for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for NameError {}

fn error(what: &'static str, name: &str, reason: impl Into<String>) -> NameError {
    NameError {
        what,
        name: name.to_owned(),
        reason: reason.into(),
    }
}

/// One `/`-separated token: letters, digits and `_`, not starting with a digit.
fn check_token(what: &'static str, name: &str, token: &str) -> Result<(), NameError> {
    if token.is_empty() {
        return Err(error(
            what,
            name,
            "it has an empty part (`//`, or a `/` at the end)",
        ));
    }
    if let Some(bad) = token
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
    {
        return Err(error(
            what,
            name,
            format!("{bad:?} is not allowed: use letters, digits, `_` and `/` between parts"),
        ));
    }
    if token.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(error(
            what,
            name,
            format!("part {token:?} starts with a digit"),
        ));
    }
    Ok(())
}

/// A security enclave's name as rcl accepts it (`rcl_validate_enclave_name`):
/// absolute, `/`-separated parts of letters, digits and `_`, none starting
/// with a digit; `/` alone is the root enclave.
pub fn validate_enclave(enclave: &str) -> Result<(), NameError> {
    const WHAT: &str = "enclave";
    if !enclave.starts_with('/') {
        return Err(error(WHAT, enclave, "it must be absolute (start with `/`)"));
    }
    if enclave == "/" {
        return Ok(());
    }
    enclave[1..]
        .split('/')
        .try_for_each(|token| check_token(WHAT, enclave, token))
}

/// The enclave a command line's ROS arguments give (`--enclave` or `-e`
/// after `--ros-args`; the last one wins, as in rcl), checked.
pub fn ros_args_enclave<I, S>(args: I) -> Result<Option<String>, NameError>
where
    I: IntoIterator<Item = S>,
    S: AsRef<str>,
{
    let mut enclave = None;
    let mut in_ros_args = false;
    let mut args = args.into_iter();
    while let Some(arg) = args.next() {
        match arg.as_ref() {
            "--ros-args" => in_ros_args = true,
            "--" => in_ros_args = false,
            flag @ ("-e" | "--enclave") if in_ros_args => {
                let value = args
                    .next()
                    .ok_or_else(|| error("ROS argument", flag, "an enclave must follow"))?;
                validate_enclave(value.as_ref())?;
                enclave = Some(value.as_ref().to_owned());
            }
            _ => {}
        }
    }
    Ok(enclave)
}

/// A node name: non-empty, letters, digits and `_`, not starting with a digit
/// (rmw's `rmw_validate_node_name`).
pub fn validate_node_name(name: &str) -> Result<(), NameError> {
    if name.is_empty() {
        return Err(error("node name", name, "it is empty"));
    }
    if name.contains('/') {
        return Err(error(
            "node name",
            name,
            "it contains `/`: put the path in the namespace",
        ));
    }
    check_token("node name", name, name)
}

/// A namespace: absolute (`/` or `/a/b`), no trailing `/`, each part a valid
/// token (rmw's `rmw_validate_namespace`). A namespace given without the leading
/// `/` (`demo`) is taken as `/demo`, as rcl does for node options.
pub fn normalize_namespace(namespace: &str) -> Result<String, NameError> {
    let absolute = if namespace.is_empty() {
        "/".to_owned()
    } else if namespace.starts_with('/') {
        namespace.to_owned()
    } else {
        format!("/{namespace}")
    };
    if absolute != "/" {
        for token in absolute[1..].split('/') {
            check_token("namespace", namespace, token)?;
        }
    }
    Ok(absolute)
}

/// The fully qualified name of a topic (or service) `name` used by node `node`
/// in `namespace`, as rcl's `rcl_expand_topic_name` gives it: `/abs` stays,
/// `rel` becomes `<namespace>/rel`, `~` and `~/x` are the node's own
/// `<namespace>/<node>[/x]`, and `{node}`, `{ns}`, `{namespace}` are
/// substituted. The result is validated as a full topic name.
pub fn expand_topic_name(name: &str, node: &str, namespace: &str) -> Result<String, NameError> {
    const WHAT: &str = "topic name";
    if name.is_empty() {
        return Err(error(WHAT, name, "it is empty"));
    }
    if name.contains('~') && !(name == "~" || name.starts_with("~/")) {
        return Err(error(
            WHAT,
            name,
            "`~` may only start the name, as `~` or `~/…`",
        ));
    }
    let ns = if namespace == "/" { "" } else { namespace };
    let node_fqn = format!("{ns}/{node}");
    let mut expanded = if let Some(rest) = name.strip_prefix('~') {
        format!("{node_fqn}{rest}")
    } else {
        name.to_owned()
    };
    for (pattern, value) in [
        ("{node}", node),
        ("{ns}", namespace),
        ("{namespace}", namespace),
    ] {
        expanded = expanded.replace(pattern, value);
    }
    if let Some(bad) = expanded.find(['{', '}']) {
        return Err(error(
            WHAT,
            name,
            format!(
                "unknown substitution at byte {bad}: only {{node}}, {{ns}} and {{namespace}} exist"
            ),
        ));
    }
    let full = if expanded.starts_with('/') {
        expanded
    } else {
        format!("{ns}/{expanded}")
    };
    // `{ns}` of the root namespace can leave `//` at the start.
    let full = if full.starts_with("//") {
        full[1..].to_owned()
    } else {
        full
    };
    if full.len() > 1 && full.ends_with('/') {
        return Err(error(WHAT, name, "it ends with `/`"));
    }
    if full == "/" {
        return Err(error(WHAT, name, "it names no topic (`/` alone)"));
    }
    for token in full[1..].split('/') {
        check_token(WHAT, name, token)?;
    }
    Ok(full)
}

/// `ROS_DOMAIN_ID` as rcl reads it: unset or empty means 0; anything else must
/// be a whole number (rcl refuses, it never falls back silently).
pub fn domain_id_from(value: Option<&str>) -> Result<u32, NameError> {
    match value.map(str::trim) {
        None | Some("") => Ok(0),
        Some(raw) => raw.parse::<u32>().map_err(|_| {
            error(
                "ROS_DOMAIN_ID",
                raw,
                "expected a whole number (0 to 232 on DDS-compatible set-ups); unset it for 0",
            )
        }),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn enclaves_are_checked_and_read_from_ros_args() {
        use super::*;
        for good in ["/", "/talker_listener/talker", "/a1/_b"] {
            assert!(validate_enclave(good).is_ok(), "{good}");
        }
        for (bad, reason) in [
            ("talker", "absolute"),
            ("/a//b", "empty part"),
            ("/a/", "empty part"),
            ("/1a", "starts with a digit"),
            ("/a-b", "not allowed"),
        ] {
            let error = validate_enclave(bad).unwrap_err().to_string();
            assert!(error.contains(reason), "{bad}: {error}");
        }
        let args = [
            "prog",
            "--ros-args",
            "-e",
            "/one",
            "--enclave",
            "/two",
            "--",
            "-e",
            "x",
        ];
        assert_eq!(ros_args_enclave(args).unwrap(), Some("/two".to_owned()));
        assert_eq!(ros_args_enclave(["prog", "-e", "x"]).unwrap(), None);
        assert!(ros_args_enclave(["prog", "--ros-args", "--enclave", "bad"]).is_err());
        assert!(ros_args_enclave(["prog", "--ros-args", "--enclave"]).is_err());
    }

    use super::*;

    #[test]
    fn relative_private_and_absolute_names_expand_like_rcl() {
        let cases = [
            ("/chatter", "talker", "/", "/chatter"),
            ("chatter", "talker", "/", "/chatter"),
            ("rel", "talker", "/demo", "/demo/rel"),
            ("a/b", "talker", "/demo/x", "/demo/x/a/b"),
            ("/abs", "talker", "/demo", "/abs"),
            ("~", "talker", "/demo", "/demo/talker"),
            ("~/private", "talker", "/demo", "/demo/talker/private"),
            ("~/private", "talker", "/", "/talker/private"),
            ("{node}/out", "talker", "/demo", "/demo/talker/out"),
            ("{ns}/x", "talker", "/demo", "/demo/x"),
            ("{ns}/x", "talker", "/", "/x"),
        ];
        for (name, node, ns, expected) in cases {
            assert_eq!(
                expand_topic_name(name, node, ns).as_deref(),
                Ok(expected),
                "{name} in {ns}"
            );
        }
    }

    #[test]
    fn bad_names_say_what_is_wrong() {
        for (name, needle) in [
            ("a*b", "'*' is not allowed"),
            ("", "empty"),
            ("a//b", "empty part"),
            ("a/", "ends with"),
            ("/1st", "starts with a digit"),
            ("a~b", "`~` may only start"),
            ("{foo}", "unknown substitution"),
            ("a b", "' ' is not allowed"),
        ] {
            let err = expand_topic_name(name, "talker", "/").unwrap_err();
            assert!(err.to_string().contains(needle), "{name}: {err}");
            assert_eq!(format!("{err:?}"), err.to_string());
        }
    }

    #[test]
    fn node_names_and_namespaces() {
        validate_node_name("talker_2").unwrap();
        for bad in ["", "a b", "2fast", "a/b", "ä"] {
            assert!(validate_node_name(bad).is_err(), "{bad:?}");
        }
        assert_eq!(normalize_namespace("").unwrap(), "/");
        assert_eq!(normalize_namespace("/").unwrap(), "/");
        assert_eq!(normalize_namespace("demo").unwrap(), "/demo");
        assert_eq!(normalize_namespace("/a/b").unwrap(), "/a/b");
        for bad in ["/a/", "/a//b", "/1a", "/a-b"] {
            assert!(normalize_namespace(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn domain_ids() {
        assert_eq!(domain_id_from(None), Ok(0));
        assert_eq!(domain_id_from(Some("")), Ok(0));
        assert_eq!(domain_id_from(Some("42")), Ok(42));
        for bad in ["abc", "-1", "4294967296", "1.5"] {
            let err = domain_id_from(Some(bad)).unwrap_err();
            assert!(err.to_string().contains("ROS_DOMAIN_ID"), "{err}");
        }
    }
}
