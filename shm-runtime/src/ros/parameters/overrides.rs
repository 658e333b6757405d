//! Initial parameter values from the command line, as ROS passes them:
//! `--ros-args -p name:=value` and `--params-file file.yaml`.

use std::fmt;
use std::path::Path;

use yaml_serde::Value;

use super::ParameterValue;

/// A parameter value or file that cannot be used, with where and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OverrideError {
    /// The argument or file.
    pub source: String,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for OverrideError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "parameter override {}: {}", self.source, self.reason)
    }
}

impl std::error::Error for OverrideError {}

/// Which nodes an entry of a parameter file applies to: `/**` (every node),
/// `/ns/name`, `name` (`/name`), with `*` for one name part and `**` for
/// any number.
#[derive(Debug, Clone, PartialEq, Eq)]
struct NodePattern(Vec<String>);

impl NodePattern {
    fn parse(key: &str) -> Self {
        Self(
            key.trim_start_matches('/')
                .split('/')
                .filter(|p| !p.is_empty())
                .map(str::to_owned)
                .collect(),
        )
    }

    fn matches(&self, fqn: &str) -> bool {
        let parts: Vec<&str> = fqn.split('/').filter(|p| !p.is_empty()).collect();
        fn go(pattern: &[String], parts: &[&str]) -> bool {
            match (pattern.split_first(), parts.split_first()) {
                (None, None) => true,
                (Some((p, rest)), _) if p == "**" => {
                    (0..=parts.len()).any(|skip| go(rest, &parts[skip..]))
                }
                (Some((p, rest)), Some((part, others))) => {
                    (p == "*" || p == part) && go(rest, others)
                }
                _ => false,
            }
        }
        go(&self.0, &parts)
    }
}

/// Initial values of parameters, by node, in the order given: a later one
/// wins. [`RosNodeBuilder::ros_args`](crate::RosNodeBuilder::ros_args) reads
/// them; a node's declaration takes the value given for it instead of its
/// default.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParameterOverrides {
    entries: Vec<(Option<NodePattern>, String, ParameterValue)>,
}

impl ParameterOverrides {
    /// The `-p name:=value` and `--params-file file` arguments among a
    /// command line's ROS arguments (between `--ros-args` and `--` or the
    /// end), in order.
    pub fn from_ros_args<I, S>(args: I) -> Result<Self, OverrideError>
    where
        I: IntoIterator<Item = S>,
        S: AsRef<str>,
    {
        let mut out = Self::default();
        let mut in_ros_args = false;
        let mut args = args.into_iter();
        while let Some(arg) = args.next() {
            let arg = arg.as_ref();
            match arg {
                "--ros-args" => in_ros_args = true,
                "--" => in_ros_args = false,
                "-p" | "--param" | "--params-file" if in_ros_args => {
                    let Some(value) = args.next() else {
                        return Err(OverrideError {
                            source: arg.to_owned(),
                            reason: "a value must follow".into(),
                        });
                    };
                    let value = value.as_ref();
                    if arg == "--params-file" {
                        out.add_file(Path::new(value))?;
                    } else {
                        out.add_assignment(value)?;
                    }
                }
                _ => {}
            }
        }
        Ok(out)
    }

    /// Add `name:=value` (the value read as YAML: `true`, `3`, `1.5`,
    /// `text`, `[1, 2]`), for every node.
    pub fn add_assignment(&mut self, assignment: &str) -> Result<(), OverrideError> {
        let error = |reason: &str| OverrideError {
            source: format!("-p {assignment}"),
            reason: reason.to_owned(),
        };
        let (name, text) = assignment
            .split_once(":=")
            .ok_or_else(|| error("write it as name:=value"))?;
        if name.is_empty() {
            return Err(error("the name is empty"));
        }
        shm_cdr::text_limits::check_yaml(text).map_err(|e| error(&e.reason))?;
        let yaml: Value = yaml_serde::from_str(text).map_err(|e| error(&e.to_string()))?;
        let value = yaml_value(&yaml).map_err(|reason| error(&reason))?;
        self.entries.push((None, name.to_owned(), value));
        Ok(())
    }

    /// Add the parameters of a ROS 2 parameter file: node keys (`/**`,
    /// `/ns/node`, `node`), each with a `ros__parameters` map whose nested
    /// maps make `a.b` names.
    pub fn add_file(&mut self, path: &Path) -> Result<(), OverrideError> {
        let source = format!("--params-file {}", path.display());
        let error = |reason: String| OverrideError {
            source: source.clone(),
            reason,
        };
        let text = shm_cdr::text_limits::read_text_file(path).map_err(|e| error(e.to_string()))?;
        self.add_yaml(&text).map_err(error)
    }

    /// [`add_file`](Self::add_file) from the file's text.
    pub fn add_yaml_text(&mut self, text: &str) -> Result<(), OverrideError> {
        self.add_yaml(text).map_err(|reason| OverrideError {
            source: "parameter YAML".into(),
            reason,
        })
    }

    fn add_yaml(&mut self, text: &str) -> Result<(), String> {
        shm_cdr::text_limits::check_yaml(text).map_err(|e| e.reason)?;
        let document: Value = yaml_serde::from_str(text).map_err(|e| e.to_string())?;
        let Value::Mapping(nodes) = document else {
            return Err("the top level must map node names to their parameters".into());
        };
        for (node, body) in &nodes {
            let Some(node) = node.as_str() else {
                return Err(format!("node key {node:?} is not a name"));
            };
            let parameters = body
                .get("ros__parameters")
                .ok_or_else(|| format!("node {node:?} has no `ros__parameters`"))?;
            let pattern = NodePattern::parse(node);
            let mut flat = Vec::new();
            flatten("", parameters, &mut flat).map_err(|e| format!("node {node:?}: {e}"))?;
            for (name, value) in flat {
                self.entries.push((Some(pattern.clone()), name, value));
            }
        }
        Ok(())
    }

    /// The values for the node `fqn` (`/ns/name`), by parameter name; a later
    /// entry wins.
    pub fn for_node(&self, fqn: &str) -> Vec<(String, ParameterValue)> {
        let mut out: Vec<(String, ParameterValue)> = Vec::new();
        for (pattern, name, value) in &self.entries {
            if pattern.as_ref().is_some_and(|p| !p.matches(fqn)) {
                continue;
            }
            match out.iter_mut().find(|(n, _)| n == name) {
                Some(slot) => slot.1 = value.clone(),
                None => out.push((name.clone(), value.clone())),
            }
        }
        out
    }

    /// These values without those of `/**` entries (`ros2 param load
    /// --no-use-wildcard`).
    pub fn without_wildcard(mut self) -> Self {
        self.entries
            .retain(|(pattern, _, _)| pattern.as_ref().is_none_or(|p| p.0 != ["**"]));
        self
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Add `other`'s values after these.
    pub fn extend(&mut self, other: ParameterOverrides) {
        self.entries.extend(other.entries);
    }
}

fn flatten(
    prefix: &str,
    value: &Value,
    out: &mut Vec<(String, ParameterValue)>,
) -> Result<(), String> {
    let Value::Mapping(map) = value else {
        return Err("`ros__parameters` must be a map".into());
    };
    for (key, value) in map {
        let key = match key {
            Value::String(s) => s.clone(),
            Value::Number(n) => n.to_string(),
            Value::Bool(b) => b.to_string(),
            other => return Err(format!("parameter name {other:?} is not a name")),
        };
        let name = if prefix.is_empty() {
            key
        } else {
            format!("{prefix}.{key}")
        };
        match value {
            Value::Mapping(_) => flatten(&name, value, out)?,
            value => out.push((
                name.clone(),
                yaml_value(value).map_err(|e| format!("{name}: {e}"))?,
            )),
        }
    }
    Ok(())
}

/// [`ParameterValue::from_yaml_text`].
pub(crate) fn value_from_yaml_text(text: &str) -> Result<ParameterValue, String> {
    shm_cdr::text_limits::check_yaml(text).map_err(|e| e.reason)?;
    let yaml: Value = yaml_serde::from_str(text).map_err(|e| e.to_string())?;
    yaml_value(&yaml)
}

/// A YAML scalar or sequence as a parameter value: one type per sequence.
fn yaml_value(value: &Value) -> Result<ParameterValue, String> {
    fn scalar(value: &Value) -> Result<ParameterValue, String> {
        match value {
            Value::Bool(b) => Ok(ParameterValue::Bool(*b)),
            Value::Number(n) => match n.as_i64() {
                Some(i) => Ok(ParameterValue::Integer(i)),
                None => n
                    .as_f64()
                    .map(ParameterValue::Double)
                    .ok_or_else(|| format!("{n} is out of range")),
            },
            Value::String(s) => Ok(ParameterValue::String(s.clone())),
            Value::Null => Err("no value".into()),
            other => Err(format!("{other:?} is not a parameter value")),
        }
    }
    let Value::Sequence(items) = value else {
        return scalar(value);
    };
    let items: Vec<ParameterValue> = items.iter().map(scalar).collect::<Result<_, _>>()?;
    macro_rules! all {
        ($variant:ident, $array:ident) => {
            items
                .iter()
                .map(|v| match v {
                    ParameterValue::$variant(x) => Some(x.clone()),
                    _ => None,
                })
                .collect::<Option<Vec<_>>>()
                .map(ParameterValue::$array)
        };
    }
    if items.is_empty() {
        return Err("an empty list has no type: give at least one element".into());
    }
    all!(Bool, BoolArray)
        .or_else(|| all!(Integer, IntegerArray))
        .or_else(|| all!(Double, DoubleArray))
        .or_else(|| all!(String, StringArray))
        .ok_or_else(|| "a list must hold values of one type".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endless_or_deep_parameter_files_are_refused_before_they_are_parsed() {
        let mut o = ParameterOverrides::default();
        let error = o.add_file(Path::new("/dev/zero")).unwrap_err();
        assert!(
            error.to_string().contains("the most read as text"),
            "{error}"
        );
        let deep = format!(
            "/**:\n  ros__parameters:\n    a: {}{}\n",
            "[".repeat(100_000),
            "]".repeat(100_000)
        );
        // Refused by a linear scan: parsing it would take minutes.
        let error = o.add_yaml_text(&deep).unwrap_err();
        assert!(error.to_string().contains("nest more than 128"), "{error}");
        let error = ParameterOverrides::from_ros_args([
            "prog".to_owned(),
            "--ros-args".to_owned(),
            "-p".to_owned(),
            format!("a:={}", "{a: ".repeat(1000)),
        ])
        .unwrap_err();
        assert!(error.to_string().contains("nest more than 128"), "{error}");
    }

    #[test]
    fn command_line_values_are_read_as_yaml() {
        let o = ParameterOverrides::from_ros_args([
            "prog",
            "--ros-args",
            "-p",
            "speed:=1.5",
            "-p",
            "count:=3",
            "--param",
            "on:=true",
            "-p",
            "name:=robot one",
            "-p",
            "ids:=[1, 2]",
            "-p",
            "speed:=2.0",
            "--",
            "-p",
            "x:=1",
        ])
        .unwrap();
        assert_eq!(
            o.for_node("/any"),
            [
                ("speed".into(), ParameterValue::Double(2.0)),
                ("count".into(), ParameterValue::Integer(3)),
                ("on".into(), ParameterValue::Bool(true)),
                ("name".into(), ParameterValue::String("robot one".into())),
                ("ids".into(), ParameterValue::IntegerArray(vec![1, 2])),
            ]
        );
        for bad in ["speed=1", ":=1", "x:=[1, a]", "x:=[]"] {
            let e = ParameterOverrides::from_ros_args(["--ros-args", "-p", bad]).unwrap_err();
            assert!(e.to_string().contains(bad), "{e}");
        }
    }

    #[test]
    fn parameter_files_apply_by_node_name_and_nest_names() {
        let mut o = ParameterOverrides::default();
        o.add_yaml_text(
            "/**:\n  ros__parameters:\n    use_sim_time: true\n    limits: {speed: 1.0}\n\
             /robot/driver:\n  ros__parameters:\n    limits:\n      speed: 2.5\n    frames: [base, odom]\n\
             other:\n  ros__parameters:\n    x: 1\n",
        )
        .unwrap();
        assert_eq!(
            o.for_node("/robot/driver"),
            [
                ("use_sim_time".into(), ParameterValue::Bool(true)),
                ("limits.speed".into(), ParameterValue::Double(2.5)),
                (
                    "frames".into(),
                    ParameterValue::StringArray(vec!["base".into(), "odom".into()])
                ),
            ]
        );
        assert_eq!(o.for_node("/other").len(), 3);
        assert!(NodePattern::parse("/**/driver").matches("/robot/driver"));
        assert!(!NodePattern::parse("/*/driver").matches("/a/b/driver"));
        assert!(o.add_yaml_text("/**:\n  params: {}\n").is_err());
    }
}
