//! `shm-ros2 param …`: ros2param's verbs and output.

use std::io::Write;

use clap::Subcommand;
use shm_cdr::dynamic::{python_float, YamlValue};
use shm_interface::python::string_repr;
use shm_runtime::parameters::{ParameterClient, ParameterOverrides, ParameterValue};

use crate::context::Context;
use crate::python::bytes_repr;
use crate::Error;

#[derive(Debug, Subcommand)]
pub(crate) enum ParamCommand {
    /// Output a list of available parameters.
    List {
        /// Name of the ROS node; every node's by default.
        node_name: Option<String>,
        /// Print parameter types with parameter names.
        #[arg(short = 't', long)]
        param_type: bool,
        /// Only list parameters with these prefixes.
        #[arg(long, num_args = 1..)]
        param_prefixes: Vec<String>,
    },
    /// Get parameter.
    Get {
        /// Name of the ROS node.
        node_name: String,
        /// Name of the parameter.
        parameter_name: String,
        /// Hide the type information.
        #[arg(long)]
        hide_type: bool,
    },
    /// Set parameter.
    Set {
        /// Name of the ROS node.
        node_name: String,
        /// Name of the parameter.
        parameter_name: String,
        /// Value of the parameter, read as YAML (`true`, `3`, `1.5`, `[1, 2]`;
        /// anything else is a string).
        value: String,
    },
    /// Show all of the parameters of a node in a YAML file format.
    Dump {
        /// Name of the ROS node.
        node_name: String,
    },
    /// Load parameter file for a node.
    Load {
        /// Name of the ROS node.
        node_name: String,
        /// Parameter file.
        parameter_file: std::path::PathBuf,
        /// Do not load parameters in the '/**' namespace into the node.
        #[arg(long)]
        no_use_wildcard: bool,
    },
}

pub(crate) fn run(context: &Context, command: ParamCommand) -> Result<(), Error> {
    match command {
        ParamCommand::List {
            node_name,
            param_type,
            param_prefixes,
        } => {
            let nodes = match &node_name {
                Some(node) => vec![absolute(node)],
                None => context
                    .graph()
                    .nodes()
                    .into_iter()
                    .filter(|n| {
                        !n.rsplit('/')
                            .next()
                            .is_some_and(|name| name.starts_with('_'))
                    })
                    .collect(),
            };
            let mut out = std::io::stdout().lock();
            for node in nodes {
                let client = match client(context, &node) {
                    Ok(client) => client,
                    // The node asked for: an error (exit 1), as ros2cli's.
                    Err(e) if node_name.is_some() => return Err(e),
                    // One of all the nodes: said, and the others listed.
                    Err(e) => {
                        eprintln!("{e}");
                        continue;
                    }
                };
                let prefixes: Vec<&str> = param_prefixes.iter().map(String::as_str).collect();
                let mut names = client.list(&prefixes, 0)?.names;
                names.sort();
                if node_name.is_none() && !names.is_empty() {
                    writeln!(out, "{node}:")?;
                }
                let types = if param_type {
                    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
                    client.types(&refs)?
                } else {
                    Vec::new()
                };
                for (i, name) in names.iter().enumerate() {
                    match types.get(i) {
                        Some(t) => writeln!(out, "  {name} (type: {})", type_string(*t))?,
                        None => writeln!(out, "  {name}")?,
                    }
                }
            }
            Ok(())
        }
        ParamCommand::Get {
            node_name,
            parameter_name,
            hide_type,
        } => {
            let node = absolute(&node_name);
            let client = client(context, &node)?;
            let values = client.get(&[parameter_name.as_str()])?;
            let Some(value) = values.first() else {
                return Err("Parameter not set".into());
            };
            let (label, text) = describe(value);
            match (hide_type, text) {
                (true, Some(text)) => println!("{text}"),
                (false, Some(text)) => println!("{label} {text}"),
                (_, None) => println!("{label}"),
            }
            Ok(())
        }
        ParamCommand::Set {
            node_name,
            parameter_name,
            value,
        } => {
            let node = absolute(&node_name);
            let client = client(context, &node)?;
            // As rclpy's `get_parameter_value`: YAML, else the text itself.
            let value = ParameterValue::from_yaml_text(&value)
                .unwrap_or_else(|_| ParameterValue::String(value.clone()));
            let results = client.set(&[(parameter_name, value)])?;
            let Some(result) = results.first() else {
                return Err(format!("{node} answered with no result").into());
            };
            let reason = if result.reason.is_empty() {
                String::new()
            } else {
                format!(": {}", result.reason)
            };
            // A refusal is the node's answer, not the command's failure:
            // ros2param prints it on stderr and exits 0.
            if result.successful {
                println!("Set parameter successful{reason}");
            } else {
                eprintln!("Setting parameter failed{reason}");
            }
            Ok(())
        }
        ParamCommand::Dump { node_name } => dump(context, &node_name),
        ParamCommand::Load {
            node_name,
            parameter_file,
            no_use_wildcard,
        } => load(context, &node_name, &parameter_file, no_use_wildcard),
    }
}

/// `ros2 param dump`: every parameter, nested at its dots, under
/// `<node>: ros__parameters:`, as PyYAML's `yaml.dump` writes it (keys
/// sorted), then the empty line `print` adds.
fn dump(context: &Context, node_name: &str) -> Result<(), Error> {
    let node = absolute(node_name);
    let client = client(context, &node)?;
    let mut names = client.list(&[], 0)?.names;
    names.sort();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let values = client.get(&refs)?;
    let mut parameters = Vec::new();
    for (name, value) in names.iter().zip(&values) {
        if let Some(value) = yaml_of(value) {
            insert(&mut parameters, name, value);
        }
    }
    sort(&mut parameters);
    let doc = YamlValue::Map(vec![(
        node,
        YamlValue::Map(vec![(
            "ros__parameters".to_owned(),
            YamlValue::Map(parameters),
        )]),
    )]);
    println!("{}", doc.to_yaml());
    Ok(())
}

/// Put `value` at `name`, a part per `.` (`a.b` → `a: {b: …}`), as ros2param
/// nests them.
fn insert(map: &mut Vec<(String, YamlValue)>, name: &str, value: YamlValue) {
    match name.split_once('.') {
        Some((head, rest)) => {
            let at = match map.iter().position(|(k, _)| k == head) {
                Some(at) => at,
                None => {
                    map.push((head.to_owned(), YamlValue::Map(Vec::new())));
                    map.len() - 1
                }
            };
            if let YamlValue::Map(inner) = &mut map[at].1 {
                insert(inner, rest, value);
            }
        }
        None => map.push((name.to_owned(), value)),
    }
}

/// Sort every mapping by key, as `yaml.dump` does.
fn sort(map: &mut [(String, YamlValue)]) {
    map.sort_by(|a, b| a.0.cmp(&b.0));
    for (_, value) in map {
        if let YamlValue::Map(inner) = value {
            sort(inner);
        }
    }
}

/// A parameter's value as YAML data; `None` for one not set.
fn yaml_of(value: &ParameterValue) -> Option<YamlValue> {
    Some(match value {
        ParameterValue::Bool(b) => YamlValue::Bool(*b),
        ParameterValue::Integer(i) => YamlValue::Int(*i),
        ParameterValue::Double(x) => YamlValue::Float(*x),
        ParameterValue::String(s) => YamlValue::Str(s.clone()),
        ParameterValue::ByteArray(v) => {
            YamlValue::Seq(v.iter().map(|b| YamlValue::Int(i64::from(*b))).collect())
        }
        ParameterValue::BoolArray(v) => {
            YamlValue::Seq(v.iter().map(|b| YamlValue::Bool(*b)).collect())
        }
        ParameterValue::IntegerArray(v) => {
            YamlValue::Seq(v.iter().map(|i| YamlValue::Int(*i)).collect())
        }
        ParameterValue::DoubleArray(v) => {
            YamlValue::Seq(v.iter().map(|x| YamlValue::Float(*x)).collect())
        }
        ParameterValue::StringArray(v) => {
            YamlValue::Seq(v.iter().map(|s| YamlValue::Str(s.clone())).collect())
        }
        _ => return None,
    })
}

/// `ros2 param load`: the file's parameters for this node (its own entry,
/// and `/**` unless `--no-use-wildcard`), set in one call; a line per
/// parameter as ros2param prints it.
fn load(
    context: &Context,
    node_name: &str,
    file: &std::path::Path,
    no_use_wildcard: bool,
) -> Result<(), Error> {
    let node = absolute(node_name);
    let client = client(context, &node)?;
    let mut overrides = ParameterOverrides::default();
    overrides.add_file(file)?;
    if no_use_wildcard {
        overrides = overrides.without_wildcard();
    }
    let parameters = overrides.for_node(&node);
    if parameters.is_empty() {
        return Err(format!("{} has no parameters for {node}", file.display()).into());
    }
    let results = client.set(&parameters)?;
    let mut failed = false;
    for ((name, _), result) in parameters.iter().zip(&results) {
        let reason = if result.reason.is_empty() {
            String::new()
        } else {
            format!(": {}", result.reason)
        };
        if result.successful {
            println!("Set parameter {name} successful{reason}");
        } else {
            eprintln!("Set parameter {name} failed{reason}");
            failed = true;
        }
    }
    if failed {
        return Err("some parameters were not set".into());
    }
    Ok(())
}

fn absolute(node: &str) -> String {
    if node.starts_with('/') {
        node.to_owned()
    } else {
        format!("/{node}")
    }
}

/// A parameter client of `node`, once the node is on the graph and its
/// services answer.
fn client(context: &Context, node: &str) -> Result<ParameterClient, Error> {
    if context.wait_for(|g| g.contains_node(node)).is_none() {
        return Err("Node not found".into());
    }
    let client = context.node()?.parameter_client(node)?;
    if !client.wait_for_services(context.timeout) {
        return Err(format!(
            "Wait for service timed out waiting for parameter services for node {node}"
        )
        .into());
    }
    Ok(client)
}

/// rcl_interfaces' type names, as `ros2 param list -t` prints them.
fn type_string(code: u8) -> &'static str {
    match code {
        1 => "boolean",
        2 => "integer",
        3 => "double",
        4 => "string",
        5 => "byte array",
        6 => "boolean array",
        7 => "integer array",
        8 => "double array",
        9 => "string array",
        0 => "not set",
        _ => "unknown type",
    }
}

/// Python's `repr` of an `array.array` of `typecode` holding `items`.
fn python_array(typecode: char, items: Vec<String>) -> String {
    if items.is_empty() {
        format!("array('{typecode}')")
    } else {
        format!("array('{typecode}', [{}])", items.join(", "))
    }
}

/// `ros2 param get`'s label and value, the value as Python prints it.
fn describe(value: &ParameterValue) -> (&'static str, Option<String>) {
    let list = |items: Vec<String>| format!("[{}]", items.join(", "));
    let py_bool = |b: bool| if b { "True" } else { "False" }.to_owned();
    match value {
        ParameterValue::Bool(b) => ("Boolean value is:", Some(py_bool(*b))),
        ParameterValue::Integer(i) => ("Integer value is:", Some(i.to_string())),
        ParameterValue::Double(x) => ("Double value is:", Some(python_float(*x))),
        ParameterValue::String(s) => ("String value is:", Some(s.clone())),
        ParameterValue::ByteArray(v) => (
            "Byte values are:",
            Some(list(v.iter().map(|b| bytes_repr(*b)).collect())),
        ),
        ParameterValue::BoolArray(v) => (
            "Boolean values are:",
            Some(list(v.iter().map(|b| py_bool(*b)).collect())),
        ),
        // rclpy holds these two as Python arrays (`int64[]`, `float64[]`),
        // the others as lists.
        ParameterValue::IntegerArray(v) => (
            "Integer values are:",
            Some(python_array('q', v.iter().map(i64::to_string).collect())),
        ),
        ParameterValue::DoubleArray(v) => (
            "Double values are:",
            Some(python_array(
                'd',
                v.iter().map(|x| python_float(*x)).collect(),
            )),
        ),
        ParameterValue::StringArray(v) => (
            "String values are:",
            Some(list(v.iter().map(|s| string_repr(s)).collect())),
        ),
        _ => ("Parameter not set.", None),
    }
}
