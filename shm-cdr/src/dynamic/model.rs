//! The run-time type model: message types and their fields, checked once when
//! built so that decoding and encoding never meet an inconsistent type.

use std::collections::HashMap;
use std::fmt;
use std::sync::Arc;

use super::limits::{TypeLimits, MAX_FIELDS_PER_BYTE, MESSAGE_BYTES, VALUE_BYTES};
use super::structs::{Check, Element, FieldDef, StructDef};
use crate::describe::{self, Container, ContainerKind, DescribedField, FullDescription, TypeId};
use crate::text_limits::quoted;

/// A message type known at run time: the type and every type it references,
/// each checked (every nested name resolves, no type contains itself, every
/// field kind is one CDR can carry). Cheap to clone.
///
/// ```
/// use shm_cdr::dynamic::DynamicType;
/// use shm_cdr::msgs::geometry_msgs::Pose;
/// use shm_cdr::RosMessage;
///
/// let pose = DynamicType::from_description(&Pose::full_description())?;
/// assert_eq!(pose.name(), "geometry_msgs/msg/Pose");
/// assert_eq!(pose.type_hash(), Pose::type_hash());
/// # Ok::<(), shm_cdr::dynamic::TypeError>(())
/// ```
#[derive(Clone, PartialEq, Eq)]
pub struct DynamicType {
    pub(crate) inner: Arc<Types>,
}

#[derive(PartialEq, Eq)]
pub(crate) struct Types {
    /// The root first, then the referenced types sorted by name.
    pub(crate) structs: Vec<StructDef>,
    /// For each struct, how a view checks each of its fields.
    pub(crate) checks: Vec<Vec<Check>>,
    /// For each struct, how a view checks a message of it.
    pub(crate) plans: Vec<super::plan::StructPlan>,
}

impl fmt::Debug for DynamicType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DynamicType")
            .field("name", &self.name())
            .field("types", &self.inner.structs.len())
            .finish()
    }
}

/// Why a description cannot be a [`DynamicType`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TypeError {
    /// The type the problem is in.
    pub type_name: String,
    /// The field, if the problem is in one.
    pub field: Option<String>,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for TypeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.field {
            Some(field) => write!(f, "{}.{field}: {}", self.type_name, self.reason),
            None => write!(f, "{}: {}", self.type_name, self.reason),
        }
    }
}

impl std::error::Error for TypeError {}

impl TypeError {
    /// An error in type `type_name` (and `field`), the names quoted as
    /// outside text is: cut if long.
    pub(crate) fn new(type_name: &str, field: Option<&str>, reason: String) -> Self {
        Self {
            type_name: quoted(type_name),
            field: field.map(quoted),
            reason,
        }
    }
}

impl DynamicType {
    /// The type described by `description` (e.g. `T::full_description()` of a
    /// compiled type), within the default [`TypeLimits`].
    pub fn from_description(description: &FullDescription) -> Result<Self, TypeError> {
        Self::from_description_with(description, &TypeLimits::DEFAULT)
    }

    /// [`from_description`](Self::from_description) within `limits`.
    pub fn from_description_with(
        description: &FullDescription,
        limits: &TypeLimits,
    ) -> Result<Self, TypeError> {
        let all = std::iter::once(&description.own).chain(&description.referenced);
        Self::from_described(
            all.map(|d| {
                (
                    d.type_name,
                    d.fields
                        .iter()
                        .map(|f| DescribedField {
                            name: f.name,
                            type_id: f.field_type.type_id(),
                            capacity: f.field_type.capacity() as u64,
                            string_capacity: f.field_type.string_capacity as u64,
                            nested_type_name: f.field_type.nested_type_name,
                            default_value: f.default_value,
                        })
                        .collect::<Vec<_>>(),
                )
            }),
            limits,
        )
    }

    /// The type described field by field: each type's name and fields, the
    /// type itself first, then every type it references (in any order),
    /// within `limits`. What every other constructor reads its description
    /// into; a description held at run time (from interface files, say)
    /// gives its fields with [`DescribedFieldBuf::as_described`].
    ///
    /// [`DescribedFieldBuf::as_described`]: crate::describe::DescribedFieldBuf::as_described
    ///
    /// ```
    /// use shm_cdr::describe::{type_id, ContainerKind, DescribedFieldBuf, TypeId};
    /// use shm_cdr::dynamic::{DynamicType, TypeLimits};
    ///
    /// let cells = DescribedFieldBuf {
    ///     name: "cells".into(),
    ///     type_id: type_id(TypeId::Float32, ContainerKind::Sequence),
    ///     ..Default::default()
    /// };
    /// let ty = DynamicType::from_described(
    ///     [("demo_msgs/msg/Battery", vec![cells.as_described()])],
    ///     &TypeLimits::DEFAULT,
    /// )?;
    /// assert_eq!(ty.default_message().to_yaml(), "cells: []\n");
    /// # Ok::<(), shm_cdr::dynamic::TypeError>(())
    /// ```
    pub fn from_described<'a, F>(
        types: impl IntoIterator<Item = (&'a str, F)>,
        limits: &TypeLimits,
    ) -> Result<Self, TypeError>
    where
        F: IntoIterator<Item = DescribedField<'a>>,
    {
        Self::build(
            types
                .into_iter()
                .map(|(name, fields)| (name, fields.into_iter().collect())),
            limits,
        )
    }

    /// The type a `type_description_interfaces/msg/TypeDescription` describes:
    /// what a node's `~/get_type_description` returns. Any node can answer
    /// with any description: it is built within the default [`TypeLimits`].
    #[cfg(feature = "type_description_interfaces")]
    pub fn from_type_description_msg(
        description: &crate::msgs::type_description_interfaces::msg::TypeDescription,
    ) -> Result<Self, TypeError> {
        Self::from_type_description_msg_with(description, &TypeLimits::DEFAULT)
    }

    /// [`from_type_description_msg`](Self::from_type_description_msg) within
    /// `limits`.
    #[cfg(feature = "type_description_interfaces")]
    pub fn from_type_description_msg_with(
        description: &crate::msgs::type_description_interfaces::msg::TypeDescription,
        limits: &TypeLimits,
    ) -> Result<Self, TypeError> {
        let all = std::iter::once(&description.type_description)
            .chain(&description.referenced_type_descriptions);
        Self::from_described(
            all.map(|d| {
                (
                    d.type_name.as_str(),
                    d.fields
                        .iter()
                        .map(|f| DescribedField {
                            name: &f.name,
                            type_id: f.r#type.type_id,
                            capacity: f.r#type.capacity,
                            string_capacity: f.r#type.string_capacity,
                            nested_type_name: f.r#type.nested_type_name.as_str(),
                            default_value: &f.default_value,
                        })
                        .collect::<Vec<_>>(),
                )
            }),
            limits,
        )
    }

    /// The type a rosidl `.json` type description describes (what rosidl
    /// installs beside each interface, `share/<pkg>/msg/<Name>.json`: its
    /// `type_description_msg`, and the `type_hashes` it is checked against).
    /// The bare `type_description_msg` object is read too.
    ///
    /// ```
    /// use shm_cdr::dynamic::DynamicType;
    ///
    /// let json = r#"{"type_description_msg": {"type_description": {"type_name": "demo_msgs/msg/Level",
    ///     "fields": [{"name": "value", "type": {"type_id": 11, "capacity": 0, "string_capacity": 0,
    ///     "nested_type_name": ""}, "default_value": "0.5"}]}, "referenced_type_descriptions": []}}"#;
    /// let ty = DynamicType::from_rosidl_json(json)?;
    /// assert_eq!(ty.name(), "demo_msgs/msg/Level");
    /// assert_eq!(ty.default_message().value("value"), Some(&shm_cdr::dynamic::Value::F64(0.5)));
    /// # Ok::<(), shm_cdr::dynamic::TypeError>(())
    /// ```
    #[cfg(feature = "yaml")]
    pub fn from_rosidl_json(text: &str) -> Result<Self, TypeError> {
        Self::from_rosidl_json_with(text, &TypeLimits::DEFAULT)
    }

    /// [`from_rosidl_json`](Self::from_rosidl_json) within `limits`.
    #[cfg(feature = "yaml")]
    pub fn from_rosidl_json_with(text: &str, limits: &TypeLimits) -> Result<Self, TypeError> {
        use yaml_serde::Value;
        let error = |reason: String| TypeError {
            type_name: "(rosidl JSON)".into(),
            field: None,
            reason,
        };
        crate::text_limits::check_yaml(text).map_err(|e| error(e.reason))?;
        let root: Value =
            yaml_serde::from_str(text).map_err(|e| error(format!("not JSON: {e}")))?;
        let msg = root.get("type_description_msg").unwrap_or(&root);
        let str_of = |v: &Value, key: &str| -> Result<String, TypeError> {
            v.get(key)
                .and_then(Value::as_str)
                .map(str::to_owned)
                .ok_or_else(|| error(format!("no string `{key}`")))
        };
        let u64_of = |v: &Value, key: &str| -> Result<u64, TypeError> {
            v.get(key)
                .and_then(Value::as_u64)
                .ok_or_else(|| error(format!("no number `{key}`")))
        };
        // (type name, [(name, type_id, capacity, string_capacity, nested, default)])
        type Fields = Vec<(String, u8, u64, u64, String, String)>;
        let mut types: Vec<(String, Fields)> = Vec::new();
        let own = msg
            .get("type_description")
            .ok_or_else(|| error("no `type_description`".into()))?;
        let referenced = match msg.get("referenced_type_descriptions") {
            Some(Value::Sequence(items)) => items.as_slice(),
            Some(_) => return Err(error("`referenced_type_descriptions` is not a list".into())),
            None => &[],
        };
        for description in std::iter::once(own).chain(referenced) {
            let name = str_of(description, "type_name")?;
            let Some(Value::Sequence(fields)) = description.get("fields") else {
                return Err(error(format!("{}: no list `fields`", quoted(&name))));
            };
            let mut out = Vec::with_capacity(fields.len());
            for field in fields {
                let ty = field
                    .get("type")
                    .ok_or_else(|| error(format!("{}: a field without `type`", quoted(&name))))?;
                let type_id = u8::try_from(u64_of(ty, "type_id")?)
                    .map_err(|_| error(format!("{}: a type_id beyond 255", quoted(&name))))?;
                out.push((
                    str_of(field, "name")?,
                    type_id,
                    u64_of(ty, "capacity")?,
                    u64_of(ty, "string_capacity")?,
                    str_of(ty, "nested_type_name")?,
                    field
                        .get("default_value")
                        .and_then(Value::as_str)
                        .unwrap_or_default()
                        .to_owned(),
                ));
            }
            types.push((name, out));
        }
        let ty = Self::from_described(
            types.iter().map(|(name, fields)| {
                (
                    name.as_str(),
                    fields
                        .iter()
                        .map(|(n, id, cap, scap, nested, default)| DescribedField {
                            name: n,
                            type_id: *id,
                            capacity: *cap,
                            string_capacity: *scap,
                            nested_type_name: nested,
                            default_value: default,
                        })
                        .collect::<Vec<_>>(),
                )
            }),
            limits,
        )?;
        // rosidl's own hash of the type, where the file gives it.
        let listed = root
            .get("type_hashes")
            .and_then(Value::as_sequence)
            .and_then(|hashes| {
                hashes.iter().find_map(|h| {
                    (h.get("type_name")?.as_str()? == ty.name())
                        .then(|| h.get("hash_string")?.as_str().map(str::to_owned))?
                })
            });
        if let Some(listed) = listed {
            let computed = ty.type_hash();
            if listed != computed {
                return Err(TypeError {
                    type_name: ty.name().to_owned(),
                    field: None,
                    reason: format!("the file's hash {listed} is not the description's {computed}"),
                });
            }
        }
        Ok(ty)
    }

    /// Build from (type name, fields) pairs, the root first, within `limits`.
    pub(crate) fn build<'a>(
        types: impl Iterator<Item = (&'a str, Vec<DescribedField<'a>>)>,
        limits: &TypeLimits,
    ) -> Result<Self, TypeError> {
        let mut described: Vec<(&str, Vec<DescribedField<'_>>)> = Vec::new();
        let mut total_fields = 0usize;
        for (name, fields) in types {
            check_described(name, &fields, limits)?;
            if described.len() == limits.max_types {
                return Err(TypeError::new(
                    name,
                    None,
                    format!(
                        "the description holds more than {} types (`TypeLimits::max_types`)",
                        limits.max_types
                    ),
                ));
            }
            total_fields = total_fields.saturating_add(fields.len());
            if total_fields > limits.max_fields {
                return Err(TypeError::new(
                    name,
                    None,
                    format!(
                        "the description's types have more than {} fields together \
                         (`TypeLimits::max_fields`)",
                        limits.max_fields
                    ),
                ));
            }
            described.push((name, fields));
        }
        let types = described;
        let mut index: HashMap<&str, usize> = HashMap::new();
        for (i, (name, _)) in types.iter().enumerate() {
            if index.insert(name, i).is_some() {
                return Err(TypeError::new(name, None, "described twice".into()));
            }
        }
        let mut structs = Vec::with_capacity(types.len());
        for (name, fields) in &types {
            if fields.is_empty() {
                return Err(TypeError::new(
                    name,
                    None,
                    "no fields (an empty message lists `structure_needs_at_least_one_member`)"
                        .into(),
                ));
            }
            let mut defs = Vec::with_capacity(fields.len());
            let mut names = std::collections::HashSet::with_capacity(fields.len());
            for f in fields {
                if !names.insert(f.name) {
                    return Err(TypeError::new(
                        name,
                        Some(f.name),
                        "a second field of this name".into(),
                    ));
                }
                let (element, container) =
                    field_kind(f, &index).map_err(|r| TypeError::new(name, Some(f.name), r))?;
                defs.push(FieldDef {
                    name: f.name.to_owned(),
                    element,
                    container,
                    default_value: f.default_value.to_owned(),
                    described: (
                        f.type_id,
                        f.capacity,
                        f.string_capacity,
                        f.nested_type_name.to_owned(),
                    ),
                });
            }
            structs.push(StructDef {
                name: (*name).to_owned(),
                fields: defs,
                min_wire_size: 1,
            });
        }
        let order = nesting_order(&structs)?;
        let blocks = measure(&mut structs, &order, limits)?;
        let checks: Vec<Vec<Check>> = structs
            .iter()
            .map(|def| {
                def.fields
                    .iter()
                    .map(|f| match (f.container, f.element) {
                        (Container::Single, Element::Bool) => Check::Bool,
                        (Container::Single, Element::String(bound)) => Check::String(bound),
                        (Container::Single, Element::WString(bound)) => Check::WString(bound),
                        (Container::Single, Element::Message(index)) => Check::Message {
                            index,
                            width: structs.get(index).map_or(0, |s| s.fields.len()),
                        },
                        (Container::Single, element) => {
                            Check::Number(element.min_wire_size(&structs))
                        }
                        (container, element) => Check::Many {
                            element,
                            container,
                            min: element.min_wire_size(&structs),
                        },
                    })
                    .collect()
            })
            .collect();
        let plans = super::plan::plans(&structs, &checks, &order, &blocks);
        Ok(Self {
            inner: Arc::new(Types {
                structs,
                checks,
                plans,
            }),
        })
    }

    /// `pkg/msg/Name` of the type.
    pub fn name(&self) -> &str {
        &self.root().name
    }

    /// The type itself.
    pub fn root(&self) -> &StructDef {
        &self.inner.structs[0]
    }

    /// The type, then every type it references, sorted by name.
    pub fn structs(&self) -> &[StructDef] {
        &self.inner.structs
    }

    /// The REP 2011 hash of the type, computed from this model as rosidl
    /// computes it.
    pub fn type_hash(&self) -> String {
        let structs = &self.inner.structs;
        let mut rest: Vec<usize> = (1..structs.len()).collect();
        rest.sort_by(|&a, &b| structs[a].name.cmp(&structs[b].name));
        // Only what the root reaches enters the hash.
        let reached = self.reached_from_root();
        let order = std::iter::once(0).chain(rest.into_iter().filter(|i| reached[*i]));
        let json = describe::description_json(
            order.map(|i| {
                let def = &structs[i];
                (
                    def.name.as_str(),
                    def.fields.iter().map(FieldDef::described),
                )
            }),
            false,
        );
        describe::rihs01_of_json(&json)
    }

    /// One of the types this type uses, as a type of its own: the request
    /// (`pkg/srv/Name_Request`) or response of a service type, say, or any
    /// nested message. `None` if this type does not use `name`.
    ///
    /// ```
    /// use shm_cdr::dynamic::DynamicType;
    /// use shm_cdr::RosMessage;
    ///
    /// #[derive(RosMessage)]
    /// #[ros(type_name = "demo_msgs/msg/Cell")]
    /// struct Cell { volts: f32 }
    ///
    /// #[derive(RosMessage)]
    /// #[ros(type_name = "demo_msgs/msg/Battery")]
    /// struct Battery { cells: Vec<Cell> }
    ///
    /// let battery = DynamicType::from_description(&Battery::full_description())?;
    /// let cell = battery.member("demo_msgs/msg/Cell").unwrap();
    /// assert_eq!(cell.type_hash(), Cell::type_hash());
    /// # Ok::<(), shm_cdr::dynamic::TypeError>(())
    /// ```
    pub fn member(&self, name: &str) -> Option<Self> {
        let structs = &self.inner.structs;
        let at = structs.iter().position(|s| s.name == name)?;
        let order = std::iter::once(at).chain((0..structs.len()).filter(|&i| i != at));
        Self::from_described(
            order.map(|i| {
                (
                    structs[i].name.as_str(),
                    structs[i].fields.iter().map(FieldDef::described),
                )
            }),
            &TypeLimits::UNLIMITED,
        )
        .ok()
    }

    /// The `.msg` text of each message type this type uses, its own first,
    /// written back from the description (field lines only: a description
    /// carries no comments or constants), as `(pkg/msg/Name, text)`.
    pub fn msg_texts(&self) -> Vec<(&str, String)> {
        let reached = self.reached_from_root();
        self.inner
            .structs
            .iter()
            .zip(reached)
            .filter(|(_, reached)| *reached)
            .map(|(def, _)| {
                let text = describe::msg_text(def.fields.iter().map(FieldDef::described));
                (def.name.as_str(), text)
            })
            .collect()
    }

    /// The type as `type_description_interfaces/msg/TypeDescription`: what a
    /// node's `~/get_type_description` answers for it, the type first, then
    /// every type it uses, sorted by name. Built back into a type with
    /// [`from_type_description_msg`](Self::from_type_description_msg), it has
    /// the same hash.
    ///
    /// ```
    /// use shm_cdr::dynamic::DynamicType;
    /// use shm_cdr::msgs::geometry_msgs::msg::PoseStamped;
    /// use shm_cdr::RosMessage;
    ///
    /// let ty = DynamicType::from_description(&PoseStamped::full_description())?;
    /// let msg = ty.to_type_description_msg();
    /// assert_eq!(msg.type_description.type_name.as_str(), "geometry_msgs/msg/PoseStamped");
    /// assert_eq!(DynamicType::from_type_description_msg(&msg)?.type_hash(), PoseStamped::type_hash());
    /// # Ok::<(), shm_cdr::dynamic::TypeError>(())
    /// ```
    #[cfg(feature = "type_description_interfaces")]
    pub fn to_type_description_msg(
        &self,
    ) -> crate::msgs::type_description_interfaces::msg::TypeDescription {
        use crate::msgs::type_description_interfaces::msg as td;
        let individual = |def: &StructDef| td::IndividualTypeDescription {
            type_name: def.name.as_str().into(),
            fields: def.fields.iter().map(|f| f.described().into()).collect(),
        };
        let structs = &self.inner.structs;
        let mut referenced: Vec<&StructDef> = structs
            .iter()
            .zip(self.reached_from_root())
            .skip(1)
            .filter_map(|(def, reached)| reached.then_some(def))
            .collect();
        referenced.sort_by(|a, b| a.name.cmp(&b.name));
        td::TypeDescription {
            type_description: individual(self.root()),
            referenced_type_descriptions: referenced.into_iter().map(individual).collect(),
        }
    }

    fn reached_from_root(&self) -> Vec<bool> {
        let structs = &self.inner.structs;
        let mut reached = vec![false; structs.len()];
        let mut todo = vec![0];
        while let Some(i) = todo.pop() {
            if std::mem::replace(&mut reached[i], true) {
                continue;
            }
            for f in &structs[i].fields {
                if let Element::Message(j) = f.element {
                    todo.push(j);
                }
            }
        }
        reached
    }
}

/// A described type's names and default texts checked against `limits`
/// before anything is made of them.
fn check_described(
    name: &str,
    fields: &[DescribedField<'_>],
    limits: &TypeLimits,
) -> Result<(), TypeError> {
    let max = limits.max_name_len;
    let too_long = |what: &str, len: usize| {
        format!("{what} is {len} bytes long, more than {max} (`TypeLimits::max_name_len`)")
    };
    if name.len() > max {
        return Err(TypeError::new(
            name,
            None,
            too_long("the type name", name.len()),
        ));
    }
    for f in fields {
        let error = |reason| Err(TypeError::new(name, Some(f.name), reason));
        if f.name.len() > max {
            return error(too_long("the field name", f.name.len()));
        }
        if f.nested_type_name.len() > max {
            return error(too_long("the nested type name", f.nested_type_name.len()));
        }
        if f.default_value.len() > limits.max_default_len {
            return error(format!(
                "the default value is {} bytes long, more than {} (`TypeLimits::max_default_len`)",
                f.default_value.len(),
                limits.max_default_len
            ));
        }
    }
    Ok(())
}

/// Each type's depth, least size on the wire and in memory and how many
/// fields a message of it holds, worked out from the innermost types out
/// (`order`) and checked against `limits`; the least wire sizes are kept in
/// `structs`, the field counts (a view's block of slots) returned.
fn measure(
    structs: &mut [StructDef],
    order: &[usize],
    limits: &TypeLimits,
) -> Result<Vec<usize>, TypeError> {
    let n = structs.len();
    let mut depth = vec![1usize; n];
    let mut blocks = vec![0usize; n];
    let mut memory = vec![0usize; n];
    let (value, message) = (VALUE_BYTES, MESSAGE_BYTES);
    for &i in order {
        let def = &structs[i];
        let error = |field: Option<&str>, reason| Err(TypeError::new(&def.name, field, reason));
        let mut wire = 0usize;
        // Slots: one per field, those of messages nested by value in their
        // place (see `plan::StructPlan::block`).
        let mut block = 0usize;
        let mut bytes = message.saturating_add(def.fields.len().saturating_mul(value));
        // The field that adds most memory, named when there is too much.
        let mut largest = ("", 0usize);
        for f in &def.fields {
            let n = match f.container {
                Container::Array(n) => n,
                _ => 1,
            };
            // Memory one element takes beyond its `Value`, or in an array.
            let (element_bytes, element_wire) = match f.element {
                Element::Message(j) => {
                    if depth[j] >= depth[i] {
                        depth[i] = depth[j] + 1;
                        if depth[i] > limits.max_depth {
                            return error(
                                Some(&f.name),
                                format!(
                                    "messages nest more than {} levels deep through this field \
                                     (`TypeLimits::max_depth`)",
                                    limits.max_depth
                                ),
                            );
                        }
                    }
                    block = block.saturating_add(if f.container == Container::Single {
                        blocks[j]
                    } else {
                        1
                    });
                    (memory[j], structs[j].min_wire_size)
                }
                Element::String(_) => {
                    block = block.saturating_add(1);
                    (std::mem::size_of::<std::borrow::Cow<'_, str>>(), 4)
                }
                Element::WString(_) => {
                    block = block.saturating_add(1);
                    (std::mem::size_of::<String>(), 4)
                }
                element => {
                    block = block.saturating_add(1);
                    let size = element.min_wire_size(structs);
                    (size, size)
                }
            };
            let field_wire = match f.container {
                Container::BoundedSequence(_) | Container::Sequence => 4,
                _ => n.saturating_mul(element_wire),
            };
            wire = wire.saturating_add(field_wire);
            let field_bytes = match f.container {
                Container::Single => match f.element {
                    Element::Message(_) => element_bytes,
                    _ => f.default_value.len(),
                },
                Container::Array(_) => n.saturating_mul(element_bytes),
                // A sequence starts as its default text gives it: as many
                // items as the text has characters, at most.
                Container::BoundedSequence(_) | Container::Sequence => {
                    f.default_value.len().saturating_mul(value)
                }
            };
            bytes = bytes.saturating_add(field_bytes);
            if field_bytes >= largest.1 {
                largest = (&f.name, field_bytes);
            }
        }
        if bytes > limits.max_default_size {
            return error(
                Some(largest.0),
                format!(
                    "a message of this type takes at least {bytes} bytes, more than {} \
                     (`TypeLimits::max_default_size`)",
                    limits.max_default_size
                ),
            );
        }
        if block > limits.max_message_fields {
            return error(
                None,
                format!(
                    "a message of this type holds {block} fields with those it nests, more \
                     than {} (`TypeLimits::max_message_fields`)",
                    limits.max_message_fields
                ),
            );
        }
        let wire = wire.max(1);
        if block > wire.saturating_mul(MAX_FIELDS_PER_BYTE) {
            return error(
                None,
                format!(
                    "a message of this type holds {block} fields in as few as {wire} bytes: \
                     more than {MAX_FIELDS_PER_BYTE} per byte (empty arrays?)"
                ),
            );
        }
        blocks[i] = block;
        memory[i] = bytes;
        structs[i].min_wire_size = wire;
    }
    Ok(blocks)
}

/// The element and container of a described field, or why it has none.
fn field_kind(
    f: &DescribedField<'_>,
    index: &HashMap<&str, usize>,
) -> Result<(Element, Container), String> {
    let Some((id, kind)) = describe::split_type_id(f.type_id) else {
        return Err(match f.type_id {
            0 => "type_id 0 (not set)".into(),
            id => format!("unknown type_id {id}"),
        });
    };
    let container = match kind {
        ContainerKind::Single => Container::Single,
        ContainerKind::Array => Container::Array(array_len(f.capacity)?),
        ContainerKind::BoundedSequence => Container::BoundedSequence(count(f.capacity)?),
        ContainerKind::Sequence => Container::Sequence,
    };
    let bound = || count(f.string_capacity);
    let element = match TypeId::from_element_id(id)? {
        TypeId::Nested => match index.get(f.nested_type_name) {
            Some(&i) => Element::Message(i),
            None => {
                return Err(format!(
                    "nested type `{}` is not among the described types",
                    f.nested_type_name
                ))
            }
        },
        TypeId::Int8 => Element::I8,
        TypeId::Uint8 => Element::U8,
        TypeId::Int16 => Element::I16,
        TypeId::Uint16 => Element::U16,
        TypeId::Int32 => Element::I32,
        TypeId::Uint32 => Element::U32,
        TypeId::Int64 => Element::I64,
        TypeId::Uint64 => Element::U64,
        TypeId::Float32 => Element::F32,
        TypeId::Float64 => Element::F64,
        TypeId::Char => Element::Char,
        TypeId::Boolean => Element::Bool,
        TypeId::Byte => Element::Byte,
        TypeId::String => Element::String(None),
        TypeId::WString => Element::WString(None),
        TypeId::BoundedString => Element::String(Some(bound()?)),
        TypeId::BoundedWString => Element::WString(Some(bound()?)),
        TypeId::WChar => return Err("wchar (type_id 14) is not supported".into()),
    };
    Ok((element, container))
}

fn count(n: u64) -> Result<usize, String> {
    usize::try_from(n).map_err(|_| format!("capacity {n} does not fit this machine"))
}

/// The most elements a fixed array may have: as many as a sequence's 32-bit
/// count allows, so that a description from elsewhere cannot ask
/// [`DynamicType::default_message`] for more.
const MAX_ARRAY_LEN: u64 = u32::MAX as u64;

fn array_len(n: u64) -> Result<usize, String> {
    if n > MAX_ARRAY_LEN {
        return Err(format!(
            "an array of {n} elements: more than any ROS 2 message can carry ({MAX_ARRAY_LEN})"
        ));
    }
    count(n)
}

/// The types in an order where each comes after every type it nests; an error
/// if a type contains itself (which no message can: its size would be
/// unbounded, and a decoder would recurse without end).
fn nesting_order(structs: &[StructDef]) -> Result<Vec<usize>, TypeError> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    let mut marks = vec![Mark::New; structs.len()];
    let mut order = Vec::with_capacity(structs.len());
    for start in 0..structs.len() {
        if marks[start] != Mark::New {
            continue;
        }
        // Iterative depth-first search: (type, next field to look at).
        let mut stack = vec![(start, 0usize)];
        marks[start] = Mark::Open;
        while let Some(&mut (i, ref mut next)) = stack.last_mut() {
            let fields = &structs[i].fields;
            if let Some(f) = fields.get(*next) {
                *next += 1;
                if let Element::Message(j) = f.element {
                    match marks[j] {
                        Mark::New => {
                            marks[j] = Mark::Open;
                            stack.push((j, 0));
                        }
                        Mark::Open => {
                            return Err(TypeError::new(
                                &structs[i].name,
                                Some(&f.name),
                                format!("`{}` contains itself through this field", structs[j].name),
                            ))
                        }
                        Mark::Done => {}
                    }
                }
            } else {
                marks[i] = Mark::Done;
                order.push(i);
                stack.pop();
            }
        }
    }
    Ok(order)
}
