//! Node parameters as ROS 2 tools expect them: typed values with descriptors,
//! set under the rules and with the answers of rclpy's parameter handling,
//! served by the six `rcl_interfaces` services and announced on
//! `/parameter_events` (see [`RosNode::declare_parameter`](crate::RosNode::declare_parameter)).

mod client;
mod overrides;
mod services;
mod store;

pub use client::ParameterClient;
pub use overrides::{OverrideError, ParameterOverrides};
use std::fmt;

use shm_cdr::dynamic::python_float;
use shm_cdr::msgs::rcl_interfaces::msg as rcl;

pub(crate) use services::ParameterServer;
pub use store::SetResult;

/// A parameter's value, one of the types `rcl_interfaces/msg/ParameterType`
/// names.
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub enum ParameterValue {
    /// No value (`PARAMETER_NOT_SET`): setting it undeclares a dynamically
    /// typed parameter.
    #[default]
    NotSet,
    /// `bool`.
    Bool(bool),
    /// `integer` (64-bit).
    Integer(i64),
    /// `double`.
    Double(f64),
    /// `string`.
    String(String),
    /// `byte[]`.
    ByteArray(Vec<u8>),
    /// `bool[]`.
    BoolArray(Vec<bool>),
    /// `integer[]`.
    IntegerArray(Vec<i64>),
    /// `double[]`.
    DoubleArray(Vec<f64>),
    /// `string[]`.
    StringArray(Vec<String>),
}

/// A type code as `distro`'s rclpy prints it in its reasons: its number from
/// Kilted on (rclpy 9.1.2), its `Parameter.Type` member before (Jazzy's
/// rclpy 7.1.6: `Type.DOUBLE`; Humble's is taken to be the same).
pub(crate) fn type_name(code: u8, distro: crate::rmw::Distro) -> String {
    use crate::rmw::Distro;
    if !matches!(distro, Distro::Humble | Distro::Jazzy) {
        return code.to_string();
    }
    let member = match code {
        0 => "NOT_SET",
        1 => "BOOL",
        2 => "INTEGER",
        3 => "DOUBLE",
        4 => "STRING",
        5 => "BYTE_ARRAY",
        6 => "BOOL_ARRAY",
        7 => "INTEGER_ARRAY",
        8 => "DOUBLE_ARRAY",
        9 => "STRING_ARRAY",
        _ => return code.to_string(),
    };
    format!("Type.{member}")
}

impl ParameterValue {
    /// A value written as `ros2 param set` and `-p name:=value` read it: YAML
    /// (`true`, `3`, `1.5`, `text`, `[1, 2]`; a list of one type).
    ///
    /// ```
    /// use shm_runtime::parameters::ParameterValue;
    ///
    /// assert_eq!(ParameterValue::from_yaml_text("3"), Ok(ParameterValue::Integer(3)));
    /// assert_eq!(ParameterValue::from_yaml_text("[1.5, 2.5]"), Ok(ParameterValue::DoubleArray(vec![1.5, 2.5])));
    /// assert!(ParameterValue::from_yaml_text("[1, a]").is_err());
    /// ```
    pub fn from_yaml_text(text: &str) -> Result<Self, String> {
        overrides::value_from_yaml_text(text)
    }

    /// The `rcl_interfaces/msg/ParameterType` code.
    pub fn type_code(&self) -> u8 {
        match self {
            Self::NotSet => 0,
            Self::Bool(_) => 1,
            Self::Integer(_) => 2,
            Self::Double(_) => 3,
            Self::String(_) => 4,
            Self::ByteArray(_) => 5,
            Self::BoolArray(_) => 6,
            Self::IntegerArray(_) => 7,
            Self::DoubleArray(_) => 8,
            Self::StringArray(_) => 9,
        }
    }

    /// As `rcl_interfaces/msg/ParameterValue`.
    pub fn to_msg(&self) -> rcl::ParameterValue {
        let mut msg = rcl::ParameterValue {
            r#type: self.type_code(),
            ..Default::default()
        };
        match self {
            Self::NotSet => {}
            Self::Bool(v) => msg.bool_value = *v,
            Self::Integer(v) => msg.integer_value = *v,
            Self::Double(v) => msg.double_value = *v,
            Self::String(v) => msg.string_value = v.clone(),
            Self::ByteArray(v) => msg.byte_array_value = v.clone(),
            Self::BoolArray(v) => msg.bool_array_value = v.clone(),
            Self::IntegerArray(v) => msg.integer_array_value = v.clone(),
            Self::DoubleArray(v) => msg.double_array_value = v.clone(),
            Self::StringArray(v) => msg.string_array_value = v.clone(),
        }
        msg
    }

    /// From `rcl_interfaces/msg/ParameterValue`; an unknown type code is
    /// [`NotSet`](Self::NotSet), as rclpy reads it.
    pub fn from_msg(msg: &rcl::ParameterValue) -> Self {
        match msg.r#type {
            1 => Self::Bool(msg.bool_value),
            2 => Self::Integer(msg.integer_value),
            3 => Self::Double(msg.double_value),
            4 => Self::String(msg.string_value.clone()),
            5 => Self::ByteArray(msg.byte_array_value.clone()),
            6 => Self::BoolArray(msg.bool_array_value.clone()),
            7 => Self::IntegerArray(msg.integer_array_value.clone()),
            8 => Self::DoubleArray(msg.double_array_value.clone()),
            9 => Self::StringArray(msg.string_array_value.clone()),
            _ => Self::NotSet,
        }
    }
}

impl fmt::Display for ParameterValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotSet => f.write_str("not set"),
            Self::Bool(v) => write!(f, "{v}"),
            Self::Integer(v) => write!(f, "{v}"),
            Self::Double(v) => f.write_str(&python_float(*v)),
            Self::String(v) => f.write_str(v),
            Self::ByteArray(v) => write!(f, "{v:?}"),
            Self::BoolArray(v) => write!(f, "{v:?}"),
            Self::IntegerArray(v) => write!(f, "{v:?}"),
            Self::DoubleArray(v) => write!(f, "{v:?}"),
            Self::StringArray(v) => write!(f, "{v:?}"),
        }
    }
}

macro_rules! value_from {
    ($($ty:ty => $variant:ident $(($conv:expr))?),* $(,)?) => {$(
        impl From<$ty> for ParameterValue {
            fn from(v: $ty) -> Self {
                Self::$variant($( ($conv) )?(v))
            }
        }
    )*};
}

value_from! {
    bool => Bool,
    i64 => Integer,
    i32 => Integer(i64::from),
    f64 => Double,
    String => String,
    &str => String(str::to_owned),
    Vec<u8> => ByteArray,
    Vec<bool> => BoolArray,
    Vec<i64> => IntegerArray,
    Vec<f64> => DoubleArray,
    Vec<String> => StringArray,
}

/// A range an integer parameter must lie in, both ends included; `step`
/// (if not 0) the spacing of the values allowed from `from`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IntegerRange {
    /// One end.
    pub from: i64,
    /// The other end.
    pub to: i64,
    /// The spacing of allowed values from the lower end, or 0 for any.
    pub step: u64,
}

/// A range a double parameter must lie in, both ends included (within a
/// relative 1e-6); `step` (if not 0.0) the spacing of the values allowed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloatingPointRange {
    /// One end.
    pub from: f64,
    /// The other end.
    pub to: f64,
    /// The spacing of allowed values from the lower end, or 0.0 for any.
    pub step: f64,
}

/// What a parameter is and which values it takes
/// (`rcl_interfaces/msg/ParameterDescriptor`). By default: statically typed
/// (its type is its first value's), writable, no range.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParameterDescriptor {
    /// What the parameter is for.
    pub description: String,
    /// Constraints in words, for tools to show.
    pub additional_constraints: String,
    /// Set only at declaration (and by overrides); later sets are refused.
    pub read_only: bool,
    /// Any type may be set, and `NotSet` undeclares it.
    pub dynamic_typing: bool,
    /// For an integer parameter: the values allowed.
    pub integer_range: Option<IntegerRange>,
    /// For a double parameter: the values allowed.
    pub floating_point_range: Option<FloatingPointRange>,
}

impl ParameterDescriptor {
    /// A descriptor with this description.
    pub fn new(description: &str) -> Self {
        Self {
            description: description.to_owned(),
            ..Self::default()
        }
    }

    /// Read-only.
    pub fn read_only(mut self) -> Self {
        self.read_only = true;
        self
    }

    /// Dynamically typed.
    pub fn dynamic_typing(mut self) -> Self {
        self.dynamic_typing = true;
        self
    }

    /// Integer values from `from` to `to` (both included), every `step`
    /// (0: any).
    pub fn integer_range(mut self, from: i64, to: i64, step: u64) -> Self {
        self.integer_range = Some(IntegerRange { from, to, step });
        self
    }

    /// Double values from `from` to `to` (both included), every `step`
    /// (0.0: any).
    pub fn floating_point_range(mut self, from: f64, to: f64, step: f64) -> Self {
        self.floating_point_range = Some(FloatingPointRange { from, to, step });
        self
    }

    /// As `rcl_interfaces/msg/ParameterDescriptor` of parameter `name` of
    /// type `type_code`.
    pub fn to_msg(&self, name: &str, type_code: u8) -> rcl::ParameterDescriptor {
        rcl::ParameterDescriptor {
            name: name.to_owned(),
            r#type: type_code,
            description: self.description.clone(),
            additional_constraints: self.additional_constraints.clone(),
            read_only: self.read_only,
            dynamic_typing: self.dynamic_typing,
            floating_point_range: self
                .floating_point_range
                .iter()
                .map(|r| rcl::FloatingPointRange {
                    from_value: r.from,
                    to_value: r.to,
                    step: r.step,
                })
                .collect(),
            integer_range: self
                .integer_range
                .iter()
                .map(|r| rcl::IntegerRange {
                    from_value: r.from,
                    to_value: r.to,
                    step: r.step,
                })
                .collect(),
        }
    }
}

/// A parameter could not be declared.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum ParameterError {
    /// It is declared already.
    AlreadyDeclared(String),
    /// Its name is empty.
    InvalidName(String),
    /// Its value breaks its descriptor (the reason says how, in rclpy's
    /// words).
    InvalidValue {
        /// The parameter.
        name: String,
        /// Why.
        reason: String,
    },
    /// The parameter services could not be declared.
    Zenoh(String),
}

impl fmt::Display for ParameterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::AlreadyDeclared(name) => write!(f, "parameter {name:?} is declared already"),
            Self::InvalidName(name) => write!(f, "invalid parameter name {name:?}: it is empty"),
            Self::InvalidValue { name, reason } => {
                write!(f, "parameter {name:?} cannot take its value: {reason}")
            }
            Self::Zenoh(e) => write!(f, "parameter services: {e}"),
        }
    }
}

impl std::error::Error for ParameterError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_go_to_messages_and_back() {
        for value in [
            ParameterValue::NotSet,
            true.into(),
            7i64.into(),
            1.5.into(),
            "x".into(),
            vec![1u8, 2].into(),
            vec![true].into(),
            vec![1i64, -2].into(),
            vec![0.5].into(),
            vec!["a".to_owned()].into(),
        ] {
            assert_eq!(ParameterValue::from_msg(&value.to_msg()), value);
        }
        assert_eq!(type_name(3, crate::rmw::Distro::Kilted), "3");
        assert_eq!(type_name(3, crate::rmw::Distro::Jazzy), "Type.DOUBLE");
        assert_eq!(
            type_name(7, crate::rmw::Distro::Jazzy),
            "Type.INTEGER_ARRAY"
        );
    }
}
