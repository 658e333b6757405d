//! The parameters of one node and rclpy's rules for changing them.

use shm_cdr::dynamic::python_float;
use shm_cdr::msgs::rcl_interfaces::msg as rcl;

use super::{type_name, ParameterDescriptor, ParameterError, ParameterValue};

/// The outcome of a set, as `rcl_interfaces/msg/SetParametersResult` says it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SetResult {
    /// Whether the values were applied.
    pub successful: bool,
    /// Why not.
    pub reason: String,
}

impl SetResult {
    fn ok() -> Self {
        Self {
            successful: true,
            reason: String::new(),
        }
    }

    pub(crate) fn refused(reason: String) -> Self {
        Self {
            successful: false,
            reason,
        }
    }

    /// From `rcl_interfaces/msg/SetParametersResult`.
    pub fn from_msg(msg: rcl::SetParametersResult) -> Self {
        Self {
            successful: msg.successful,
            reason: msg.reason,
        }
    }

    /// As `rcl_interfaces/msg/SetParametersResult`.
    pub fn to_msg(&self) -> rcl::SetParametersResult {
        rcl::SetParametersResult {
            successful: self.successful,
            reason: self.reason.clone(),
        }
    }
}

/// rclpy's `Node.PARAM_REL_TOL`.
const REL_TOL: f64 = 1e-6;

/// Python's `math.isclose(a, b, rel_tol=REL_TOL)`.
fn is_close(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= REL_TOL * a.abs().max(b.abs())
}

/// A validation callback: `Err(reason)` refuses the whole set.
pub(crate) type OnSet = Box<dyn FnMut(&[(String, ParameterValue)]) -> Result<(), String> + Send>;
/// Called with what was set.
pub(crate) type AfterSet = Box<dyn FnMut(&[(String, ParameterValue)]) + Send>;

struct Entry {
    name: String,
    value: ParameterValue,
    descriptor: ParameterDescriptor,
    /// The type a statically typed parameter keeps.
    type_code: u8,
}

/// What a set changed, for `/parameter_events`.
#[derive(Default)]
pub(crate) struct Changes {
    pub(crate) new: Vec<rcl::Parameter>,
    pub(crate) changed: Vec<rcl::Parameter>,
    pub(crate) deleted: Vec<rcl::Parameter>,
}

impl Changes {
    pub(crate) fn is_empty(&self) -> bool {
        self.new.is_empty() && self.changed.is_empty() && self.deleted.is_empty()
    }
}

fn parameter_msg(name: &str, value: &ParameterValue) -> rcl::Parameter {
    rcl::Parameter {
        name: name.to_owned(),
        value: value.to_msg(),
    }
}

/// The parameters of a node, in declaration order (as rclpy lists them).
#[derive(Default)]
pub(crate) struct Store {
    /// Whose rclpy's reasons the store gives.
    distro: crate::rmw::Distro,
    entries: Vec<Entry>,
    on_set: Vec<OnSet>,
    after_set: Vec<AfterSet>,
}

impl Store {
    /// An empty store giving `distro`'s rclpy's reasons.
    pub(crate) fn for_distro(distro: crate::rmw::Distro) -> Self {
        Self {
            distro,
            ..Self::default()
        }
    }

    fn find(&self, name: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.name == name)
    }

    pub(crate) fn value(&self, name: &str) -> Option<ParameterValue> {
        self.find(name).map(|e| e.value.clone())
    }

    pub(crate) fn add_on_set(&mut self, callback: OnSet) {
        self.on_set.push(callback);
    }

    pub(crate) fn add_after_set(&mut self, callback: AfterSet) {
        self.after_set.push(callback);
    }

    /// Declare `name` with `value` (checked against `descriptor`, but not
    /// refused for being read-only); what changed.
    pub(crate) fn declare(
        &mut self,
        name: &str,
        value: ParameterValue,
        descriptor: ParameterDescriptor,
    ) -> Result<Changes, ParameterError> {
        if name.is_empty() {
            return Err(ParameterError::InvalidName(name.to_owned()));
        }
        if self.find(name).is_some() {
            return Err(ParameterError::AlreadyDeclared(name.to_owned()));
        }
        if matches!(value, ParameterValue::NotSet) && !descriptor.dynamic_typing {
            return Err(ParameterError::InvalidValue {
                name: name.to_owned(),
                reason: "a statically typed parameter needs a value to take its type from".into(),
            });
        }
        let type_code = value.type_code();
        let check = check_range(name, &value, &descriptor);
        if !check.successful {
            return Err(ParameterError::InvalidValue {
                name: name.to_owned(),
                reason: check.reason,
            });
        }
        let set = [(name.to_owned(), value.clone())];
        if let Some(reason) = self.run_on_set(&set) {
            return Err(ParameterError::InvalidValue {
                name: name.to_owned(),
                reason,
            });
        }
        self.entries.push(Entry {
            name: name.to_owned(),
            value: value.clone(),
            descriptor,
            type_code,
        });
        self.run_after_set(&set);
        Ok(Changes {
            new: vec![parameter_msg(name, &value)],
            ..Changes::default()
        })
    }

    fn run_on_set(&mut self, set: &[(String, ParameterValue)]) -> Option<String> {
        self.on_set
            .iter_mut()
            .find_map(|callback| callback(set).err())
    }

    fn run_after_set(&mut self, set: &[(String, ParameterValue)]) {
        for callback in &mut self.after_set {
            callback(set);
        }
    }

    /// Set every parameter of `set` or none, as rclpy's
    /// `set_parameters_atomically`: every name declared, each value allowed by
    /// its descriptor, every validation callback agreeing.
    pub(crate) fn set_atomically(
        &mut self,
        set: &[(String, ParameterValue)],
    ) -> (SetResult, Changes) {
        let undeclared: Vec<&str> = set
            .iter()
            .map(|(name, _)| name.as_str())
            .filter(|name| self.find(name).is_none())
            .collect();
        if !undeclared.is_empty() {
            return (
                SetResult::refused(format!(
                    "parameter {} cannot be set because it was not declared",
                    undeclared
                        .iter()
                        .map(|n| format!("'{n}'"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )),
                Changes::default(),
            );
        }
        for (name, value) in set {
            if let Some(entry) = self.find(name) {
                let result = check(entry, value, self.distro);
                if !result.successful {
                    return (result, Changes::default());
                }
            }
        }
        if let Some(reason) = self.run_on_set(set) {
            return (SetResult::refused(reason), Changes::default());
        }
        let mut changes = Changes::default();
        for (name, value) in set {
            let Some(index) = self.entries.iter().position(|e| &e.name == name) else {
                continue;
            };
            if matches!(value, ParameterValue::NotSet) {
                self.entries.remove(index);
                changes.deleted.push(parameter_msg(name, value));
                continue;
            }
            let entry = &mut self.entries[index];
            if matches!(entry.value, ParameterValue::NotSet) {
                changes.new.push(parameter_msg(name, value));
            } else {
                changes.changed.push(parameter_msg(name, value));
            }
            entry.value = value.clone();
            if entry.descriptor.dynamic_typing {
                entry.type_code = value.type_code();
            }
        }
        self.run_after_set(set);
        (SetResult::ok(), changes)
    }

    /// The values of `names`, or none if one is not declared or has no value
    /// (as rclpy's service answers).
    pub(crate) fn get(&self, names: &[String]) -> Vec<rcl::ParameterValue> {
        let mut out = Vec::with_capacity(names.len());
        for name in names {
            match self.find(name) {
                Some(entry) if !matches!(entry.value, ParameterValue::NotSet) => {
                    out.push(entry.value.to_msg());
                }
                _ => return Vec::new(),
            }
        }
        out
    }

    /// The types of `names`, or none if one is not declared.
    pub(crate) fn types(&self, names: &[String]) -> Vec<u8> {
        let found: Option<Vec<u8>> = names
            .iter()
            .map(|name| self.find(name).map(|e| e.value.type_code()))
            .collect();
        found.unwrap_or_default()
    }

    /// The descriptors of `names`, or none if one is not declared.
    pub(crate) fn describe(&self, names: &[String]) -> Vec<rcl::ParameterDescriptor> {
        let found: Option<Vec<rcl::ParameterDescriptor>> = names
            .iter()
            .map(|name| {
                self.find(name)
                    .map(|e| e.descriptor.to_msg(&e.name, e.type_code))
            })
            .collect();
        found.unwrap_or_default()
    }

    /// rclpy's `list_parameters`: names under `prefixes` (all if none) down
    /// to `depth` `.`-separated levels (0: every level), with their prefixes.
    pub(crate) fn list(&self, prefixes: &[String], depth: u64) -> rcl::ListParametersResult {
        const RECURSIVE: u64 = 0;
        let within_depth = |name: &str| (name.matches('.').count() as u64) < depth;
        let recursive = prefixes.is_empty() && depth == RECURSIVE;
        let mut result = rcl::ListParametersResult::default();
        for entry in &self.entries {
            let name = entry.name.as_str();
            if !recursive {
                let all = prefixes.is_empty() && within_depth(name);
                let matches = all
                    || prefixes.iter().any(|prefix| {
                        name == prefix
                            || name
                                .strip_prefix(prefix.as_str())
                                .and_then(|rest| rest.strip_prefix('.'))
                                .is_some_and(|rest| depth == RECURSIVE || within_depth(rest))
                    });
                if !matches {
                    continue;
                }
            }
            result.names.push(name.to_owned());
            if let Some((prefix, _)) = name.rsplit_once('.') {
                if !result.prefixes.iter().any(|p| p == prefix) {
                    result.prefixes.push(prefix.to_owned());
                }
            }
        }
        result
    }
}

/// rclpy's `_apply_descriptor` for a set: read-only, type, range.
fn check(entry: &Entry, value: &ParameterValue, distro: crate::rmw::Distro) -> SetResult {
    let name = &entry.name;
    let descriptor = &entry.descriptor;
    if descriptor.read_only {
        return SetResult::refused(format!("Trying to set a read-only parameter: {name}."));
    }
    let not_set = matches!(value, ParameterValue::NotSet);
    if !descriptor.dynamic_typing {
        if not_set {
            return SetResult::refused("Static parameter cannot be undeclared".into());
        }
        if value.type_code() != entry.type_code {
            return SetResult::refused(format!(
                "Wrong parameter type, expected '{}' got '{}'",
                type_name(entry.type_code, distro),
                type_name(value.type_code(), distro)
            ));
        }
    }
    check_range(name, value, descriptor)
}

/// rclpy's `_apply_integer_range` and `_apply_floating_point_range`.
fn check_range(name: &str, value: &ParameterValue, descriptor: &ParameterDescriptor) -> SetResult {
    match (
        value,
        descriptor.integer_range,
        descriptor.floating_point_range,
    ) {
        (ParameterValue::Integer(v), Some(range), _) => {
            let (min, max) = (range.from.min(range.to), range.from.max(range.to));
            let v = *v;
            if v == min || v == max {
                return SetResult::ok();
            }
            if !(min < v && v < max) {
                return SetResult::refused(format!(
                    "Parameter {name} out of range. Min: {min}, Max: {max}, value: {v}"
                ));
            }
            let step = i128::from(range.step);
            if step != 0 && (i128::from(v) - i128::from(min)).rem_euclid(step) != 0 {
                return SetResult::refused(format!(
                    "The parameter value for {name} is not a valid step. Min: {min}, max: {max}, value: {v}, step: {}",
                    range.step
                ));
            }
            SetResult::ok()
        }
        (ParameterValue::Double(v), _, Some(range)) => {
            let (min, max) = (range.from.min(range.to), range.from.max(range.to));
            let v = *v;
            if is_close(v, min) || is_close(v, max) {
                return SetResult::ok();
            }
            if !(min < v && v < max) {
                return SetResult::refused(format!(
                    "Parameter {name} out of range Min: {}, Max: {}, value: {}",
                    python_float(min),
                    python_float(max),
                    python_float(v)
                ));
            }
            if range.step != 0.0 {
                let steps = ((v - min) / range.step).round_ties_even();
                if !is_close(min + steps * range.step, v) {
                    return SetResult::refused(format!(
                        "The parameter value for {name} is not close enough to a valid step. Min: {}, max: {}, value: {}, step: {}",
                        python_float(min),
                        python_float(max),
                        python_float(v),
                        python_float(range.step)
                    ));
                }
            }
            SetResult::ok()
        }
        _ => SetResult::ok(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(store: &mut Store, name: &str, value: impl Into<ParameterValue>) -> SetResult {
        store.set_atomically(&[(name.to_owned(), value.into())]).0
    }

    #[test]
    fn sets_follow_rclpys_rules_and_words() {
        let mut s = Store::default();
        s.declare(
            "speed",
            1.5.into(),
            ParameterDescriptor::new("m/s").floating_point_range(0.0, 10.0, 0.5),
        )
        .unwrap();
        s.declare(
            "count",
            4i64.into(),
            ParameterDescriptor::default().integer_range(0, 10, 2),
        )
        .unwrap();
        s.declare(
            "frame",
            "map".into(),
            ParameterDescriptor::default().read_only(),
        )
        .unwrap();
        s.declare(
            "any",
            1i64.into(),
            ParameterDescriptor::default().dynamic_typing(),
        )
        .unwrap();
        assert!(set(&mut s, "speed", 2.0).successful);
        assert_eq!(
            set(&mut s, "speed", 11.0).reason,
            "Parameter speed out of range Min: 0.0, Max: 10.0, value: 11.0"
        );
        assert_eq!(
            set(&mut s, "speed", 2.2).reason,
            "The parameter value for speed is not close enough to a valid step. Min: 0.0, max: 10.0, value: 2.2, step: 0.5"
        );
        assert_eq!(
            set(&mut s, "count", 3i64).reason,
            "The parameter value for count is not a valid step. Min: 0, max: 10, value: 3, step: 2"
        );
        assert_eq!(
            set(&mut s, "count", 12i64).reason,
            "Parameter count out of range. Min: 0, Max: 10, value: 12"
        );
        assert_eq!(
            set(&mut s, "speed", "fast").reason,
            "Wrong parameter type, expected '3' got '4'"
        );
        assert_eq!(
            set(&mut s, "frame", "odom").reason,
            "Trying to set a read-only parameter: frame."
        );
        assert_eq!(
            set(&mut s, "count", ParameterValue::NotSet).reason,
            "Static parameter cannot be undeclared"
        );
        assert!(set(&mut s, "any", "now a string").successful);
        let (result, changes) = s.set_atomically(&[("any".into(), ParameterValue::NotSet)]);
        assert!(result.successful && changes.deleted.len() == 1);
        assert!(s.value("any").is_none());
        assert!(!set(&mut s, "nope", 1i64).successful);
        // All or nothing.
        let (result, _) =
            s.set_atomically(&[("speed".into(), 3.0.into()), ("count".into(), 3i64.into())]);
        assert!(!result.successful);
        assert_eq!(s.value("speed"), Some(2.0.into()));
    }

    #[test]
    fn lists_by_prefix_and_depth_as_rclpy() {
        let mut s = Store::default();
        for name in ["a", "b.c", "b.d.e", "f.g"] {
            s.declare(name, 1i64.into(), ParameterDescriptor::default())
                .unwrap();
        }
        let list = |prefixes: &[&str], depth| {
            let prefixes: Vec<String> = prefixes.iter().map(|p| p.to_string()).collect();
            let r = s.list(&prefixes, depth);
            (r.names, r.prefixes)
        };
        assert_eq!(list(&[], 0).0, ["a", "b.c", "b.d.e", "f.g"]);
        assert_eq!(list(&[], 0).1, ["b", "b.d", "f"]);
        assert_eq!(list(&[], 1).0, ["a"]);
        assert_eq!(list(&["b"], 1).0, ["b.c"]);
        assert_eq!(list(&["b"], 0).0, ["b.c", "b.d.e"]);
    }
}
