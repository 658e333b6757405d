//! Remapping as rcl applies it (`rcl/remap.c`): rules `[node:]from:=to` from
//! `--ros-args -r`, tried in order, the first that matches wins. `from` and
//! `to` are expanded against the node's namespace and name before comparing,
//! so `chatter:=talk` in namespace `/demo` maps `/demo/chatter` to
//! `/demo/talk`. `__node:=` renames the node, `__ns:=` moves it.

use std::fmt;
use std::str::FromStr;

use super::{error, expand_topic_name, normalize_namespace, validate_node_name, NameError};

/// Whether a name is a topic's or a service's: rules written
/// `rostopic://from:=to` or `rosservice://from:=to` apply to one kind only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NameKind {
    /// A topic (actions are remapped as topics, as rcl_action does).
    Topic,
    /// A service.
    Service,
}

/// What a rule renames.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RemapTarget {
    /// A topic or service name (`chatter`, `~/out`, `rostopic://chatter`).
    Name {
        /// The name to match, as written (expanded when matched).
        from: String,
        /// `Some` for a `rostopic://` or `rosservice://` rule.
        only: Option<NameKind>,
    },
    /// The node's name (`__node:=` or `__name:=`).
    NodeName,
    /// The node's namespace (`__ns:=`).
    Namespace,
}

/// One remapping rule, `[node:]from:=to`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RemapRule {
    /// Only the node of this name takes the rule (`talker:chatter:=talk`).
    pub node: Option<String>,
    /// What it renames.
    pub target: RemapTarget,
    /// The replacement, as written.
    pub to: String,
}

impl RemapRule {
    /// Parse a rule as `--ros-args -r` takes it; a rule ROS would refuse is an
    /// error saying why.
    pub fn parse(rule: &str) -> Result<Self, NameError> {
        const WHAT: &str = "remapping rule";
        let Some((lhs, to)) = rule.split_once(":=") else {
            return Err(error(WHAT, rule, "expected `from:=to`"));
        };
        let scheme = |s: &str| s.starts_with("rostopic://") || s.starts_with("rosservice://");
        let (node, from) = match lhs.split_once(':') {
            Some((node, from)) if !scheme(lhs) => {
                validate_node_name(node).map_err(|e| error(WHAT, rule, e.to_string()))?;
                (Some(node.to_owned()), from)
            }
            _ => (None, lhs),
        };
        let target = match from {
            "__node" | "__name" => {
                validate_node_name(to).map_err(|e| error(WHAT, rule, e.to_string()))?;
                RemapTarget::NodeName
            }
            "__ns" => {
                if !to.starts_with('/') {
                    return Err(error(WHAT, rule, "a namespace must be absolute (`/…`)"));
                }
                normalize_namespace(to).map_err(|e| error(WHAT, rule, e.to_string()))?;
                RemapTarget::Namespace
            }
            _ => {
                let (only, name) = if let Some(name) = from.strip_prefix("rostopic://") {
                    (Some(NameKind::Topic), name)
                } else if let Some(name) = from.strip_prefix("rosservice://") {
                    (Some(NameKind::Service), name)
                } else {
                    (None, from)
                };
                // Both sides must be names that expand, for any node.
                for side in [name, to] {
                    expand_topic_name(side, "node", "/")
                        .map_err(|e| error(WHAT, rule, e.to_string()))?;
                }
                RemapTarget::Name {
                    from: name.to_owned(),
                    only,
                }
            }
        };
        Ok(Self {
            node,
            target,
            to: to.to_owned(),
        })
    }

    fn applies_to(&self, node: &str) -> bool {
        self.node.as_deref().is_none_or(|n| n == node)
    }
}

impl FromStr for RemapRule {
    type Err = NameError;
    fn from_str(rule: &str) -> Result<Self, NameError> {
        Self::parse(rule)
    }
}

impl fmt::Display for RemapRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(node) = &self.node {
            write!(f, "{node}:")?;
        }
        match &self.target {
            RemapTarget::Name { from, only } => match only {
                Some(NameKind::Topic) => write!(f, "rostopic://{from}")?,
                Some(NameKind::Service) => write!(f, "rosservice://{from}")?,
                None => f.write_str(from)?,
            },
            RemapTarget::NodeName => f.write_str("__node")?,
            RemapTarget::Namespace => f.write_str("__ns")?,
        }
        write!(f, ":={}", self.to)
    }
}

/// A node's remapping rules, in the order given.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Remaps {
    rules: Vec<RemapRule>,
}

impl Remaps {
    /// Add `rule` after the others (earlier rules win).
    pub fn push(&mut self, rule: RemapRule) {
        self.rules.push(rule);
    }

    /// Whether there are no rules.
    pub fn is_empty(&self) -> bool {
        self.rules.is_empty()
    }

    /// The name of node `node` after its `__node` rules.
    pub fn node_name(&self, node: &str) -> String {
        self.rules
            .iter()
            .find(|r| r.target == RemapTarget::NodeName && r.applies_to(node))
            .map_or_else(|| node.to_owned(), |r| r.to.clone())
    }

    /// The namespace of node `node` (its name after renaming, as rcl matches
    /// it) after its `__ns` rules, or `None` to keep it.
    pub fn namespace(&self, node: &str) -> Option<String> {
        self.rules
            .iter()
            .find(|r| r.target == RemapTarget::Namespace && r.applies_to(node))
            .map(|r| r.to.clone())
    }

    /// `expanded` (a fully qualified name of `kind`) after the first rule
    /// that matches it, for node `node` in `namespace`.
    pub fn name(
        &self,
        expanded: &str,
        kind: NameKind,
        node: &str,
        namespace: &str,
    ) -> Result<String, NameError> {
        for rule in &self.rules {
            let RemapTarget::Name { from, only } = &rule.target else {
                continue;
            };
            if !rule.applies_to(node) || only.is_some_and(|k| k != kind) {
                continue;
            }
            if expand_topic_name(from, node, namespace)? == expanded {
                return expand_topic_name(&rule.to, node, namespace);
            }
        }
        Ok(expanded.to_owned())
    }
}

/// The remapping rules in a command line's ROS arguments (what follows
/// `--ros-args`, up to `--`), e.g. `std::env::args()` of a program started by
/// `ros2 launch`: `-r`/`--remap` rules are returned; parameters, logging and
/// enclave options are skipped (others read them); anything else
/// is an error, as rcl refuses unknown ROS arguments.
pub fn ros_args_remaps<I, S>(args: I) -> Result<Vec<RemapRule>, NameError>
where
    I: IntoIterator<Item = S>,
    S: AsRef<str>,
{
    const WHAT: &str = "ROS argument";
    let mut rules = Vec::new();
    let mut in_ros_args = false;
    let mut args = args.into_iter();
    while let Some(arg) = args.next() {
        let arg = arg.as_ref();
        match arg {
            "--ros-args" => in_ros_args = true,
            _ if !in_ros_args => {}
            "--" => in_ros_args = false,
            "-r" | "--remap" => {
                let rule = args
                    .next()
                    .ok_or_else(|| error(WHAT, arg, "a rule `from:=to` must follow"))?;
                rules.push(RemapRule::parse(rule.as_ref())?);
            }
            "-p" | "--param" | "--params-file" | "-e" | "--enclave" | "--log-level"
            | "--log-config-file" | "--log-file-name" => {
                args.next()
                    .ok_or_else(|| error(WHAT, arg, "a value must follow"))?;
            }
            "--enable-rosout-logs"
            | "--disable-rosout-logs"
            | "--enable-stdout-logs"
            | "--disable-stdout-logs"
            | "--enable-external-lib-logs"
            | "--disable-external-lib-logs" => {}
            _ => {
                return Err(error(
                    WHAT,
                    arg,
                    "unknown (end ROS arguments with `--` before the program's own)",
                ))
            }
        }
    }
    Ok(rules)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn remaps(rules: &[&str]) -> Remaps {
        let mut r = Remaps::default();
        for rule in rules {
            r.push(rule.parse().unwrap());
        }
        r
    }

    #[test]
    fn rules_parse_and_print_back() {
        for rule in [
            "chatter:=talk",
            "talker:chatter:=talk",
            "rostopic://a:=b",
            "rosservice://add:=/sum",
            "__node:=renamed",
            "talker:__ns:=/robot1",
            "~/out:=/shared",
        ] {
            assert_eq!(RemapRule::parse(rule).unwrap().to_string(), rule);
        }
        assert_eq!(
            RemapRule::parse("__name:=x").unwrap().target,
            RemapTarget::NodeName
        );
        for (bad, needle) in [
            ("chatter", "expected `from:=to`"),
            ("a*b:=c", "'*' is not allowed"),
            ("a:=b c", "' ' is not allowed"),
            ("__ns:=relative", "absolute"),
            ("__node:=a/b", "contains `/`"),
            ("2node:a:=b", "starts with a digit"),
        ] {
            let err = RemapRule::parse(bad).unwrap_err();
            assert!(err.to_string().contains(needle), "{bad}: {err}");
        }
    }

    #[test]
    fn names_remap_like_rcl() {
        let r = remaps(&[
            "other:chatter:=nope",
            "chatter:=talk",
            "chatter:=second_rule_never_wins",
            "~/private:=/public",
            "rosservice://add:=sum",
            "/abs:=rel",
        ]);
        let name = |n: &str, kind| r.name(n, kind, "talker", "/demo").unwrap();
        assert_eq!(name("/demo/chatter", NameKind::Topic), "/demo/talk");
        assert_eq!(name("/chatter", NameKind::Topic), "/chatter");
        assert_eq!(name("/demo/talker/private", NameKind::Topic), "/public");
        assert_eq!(name("/demo/add", NameKind::Service), "/demo/sum");
        assert_eq!(name("/demo/add", NameKind::Topic), "/demo/add");
        assert_eq!(name("/abs", NameKind::Service), "/demo/rel");
        // The node-specific rule applies to its node only.
        assert_eq!(
            r.name("/demo/chatter", NameKind::Topic, "other", "/demo")
                .unwrap(),
            "/demo/nope"
        );
    }

    #[test]
    fn node_name_and_namespace() {
        let r = remaps(&[
            "other:__node:=x",
            "__node:=renamed",
            "renamed:__ns:=/robot1",
        ]);
        assert_eq!(r.node_name("talker"), "renamed");
        assert_eq!(r.node_name("other"), "x");
        assert_eq!(r.namespace("renamed").as_deref(), Some("/robot1"));
        assert_eq!(r.namespace("talker"), None);
    }

    #[test]
    fn command_lines() {
        let args = [
            "prog",
            "--flag",
            "--ros-args",
            "-r",
            "a:=b",
            "-p",
            "x:=1",
            "--remap",
            "__ns:=/n",
            "--log-level",
            "debug",
            "--",
            "-r",
            "not:=ros",
        ];
        let rules = ros_args_remaps(args).unwrap();
        let texts: Vec<String> = rules.iter().map(ToString::to_string).collect();
        assert_eq!(texts, ["a:=b", "__ns:=/n"]);
        assert!(ros_args_remaps(["--ros-args", "-r"]).is_err());
        let err = ros_args_remaps(["--ros-args", "--bogus"]).unwrap_err();
        assert!(err.to_string().contains("unknown"), "{err}");
        assert!(ros_args_remaps(["prog", "--bogus"]).unwrap().is_empty());
    }
}
