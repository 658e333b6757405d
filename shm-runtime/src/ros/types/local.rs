//! Interface files on disk (`<pkg>/msg/*.msg`, `srv/*.srv`, `action/*.action`),
//! read with shm-interface's parser into run-time types: for a system whose
//! nodes do not describe their types, or to record with the files' own text,
//! as rosbag2 does with the interfaces it finds installed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use shm_cdr::dynamic::{DynamicType, TypeLimits};
use shm_interface::ast::{BaseType, Message, Service};
use shm_interface::{DescribedField, DescribedFieldBuf, TypeId};

use super::definition;
use super::standard::{full_name, standard, Kind, ResolvedType};
use super::ResolvedService;
use zenoh::Error;

/// The message types of interface packages on disk, by `pkg/msg/Name` (and
/// the request, response, goal, … types rosidl derives from services and
/// actions).
#[derive(Debug, Clone, Default)]
pub struct LocalInterfaces {
    messages: BTreeMap<String, Message>,
    /// The `.srv` files by `pkg/srv/Name`, and the services rosidl derives
    /// from `.action` files (`pkg/action/Name_SendGoal`, …); their parts
    /// are in `messages`.
    services: BTreeMap<String, Service>,
}

impl LocalInterfaces {
    /// Read every package in `dirs`: a directory that holds `msg`, `srv` or
    /// `action` is a package; any other holds packages.
    pub fn load(dirs: &[PathBuf]) -> Result<Self, Error> {
        let mut out = Self::default();
        for dir in dirs {
            let packages: Vec<PathBuf> = if is_package(dir) {
                vec![dir.clone()]
            } else {
                let listing = std::fs::read_dir(dir)
                    .map_err(|e| format!("interface files: cannot list {}: {e}", dir.display()))?;
                let mut found: Vec<PathBuf> = listing
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| is_package(p))
                    .collect();
                found.sort();
                if found.is_empty() {
                    return Err(format!(
                        "interface files: {} holds no package (a directory with msg, srv or action)",
                        dir.display()
                    )
                    .into());
                }
                found
            };
            for package in packages {
                let package = shm_interface::parse::load_package(&package)
                    .map_err(|e| format!("interface files: {e}"))?;
                for message in package.all_messages() {
                    out.messages.insert(message.ty.full_name(), message.clone());
                }
                let action_services = package
                    .actions
                    .iter()
                    .flat_map(|a| [&a.send_goal, &a.get_result]);
                for service in package.services.iter().chain(action_services) {
                    out.services.insert(service.ty.full_name(), service.clone());
                }
            }
        }
        Ok(out)
    }

    /// The message types of a complete definition in rosbag2's `ros2msg` form
    /// (see [`definition`]): `type_name`'s text, then every type it uses, as a
    /// recording keeps them.
    pub fn from_definition(type_name: &str, text: &str) -> Result<Self, Error> {
        let mut out = Self::default();
        for (name, text) in definition::split(type_name, text) {
            let full = full_name(name);
            let (package, short) = match full.split('/').collect::<Vec<_>>()[..] {
                [package, "msg", short] => (package, short),
                _ => {
                    return Err(format!(
                        "the definition of {type_name} holds {name}, which is not a message type (pkg/msg/Name)"
                    )
                    .into())
                }
            };
            let file = PathBuf::from(format!("{package}/msg/{short}.msg"));
            let message = shm_interface::parse::parse_message(text, &file, package, short)
                .map_err(|e| format!("the definition of {type_name}: {e}"))?;
            out.messages.insert(full, message);
        }
        Ok(out)
    }

    /// How many message types the files give.
    pub fn len(&self) -> usize {
        self.messages.len()
    }

    /// Whether they give none.
    pub fn is_empty(&self) -> bool {
        self.messages.is_empty()
    }

    /// The message type `name` (`pkg/msg/Name`), if the files define it: a
    /// run-time type, with the files' text as its definition. A type it uses
    /// comes from the files too, else from the standard set.
    pub fn resolve(&self, name: &str) -> Option<Result<ResolvedType, Error>> {
        self.messages.get(name)?;
        Some(self.build(name, BTreeMap::new(), BTreeMap::new()))
    }

    /// The service type `name` (`pkg/srv/Name`, or an action's
    /// `pkg/action/Name_SendGoal` or `…_GetResult`), if the files define it: its request and response as run-time types, and the service's
    /// RIHS01 hash as rosidl computes it (over the request, the response
    /// and the event message rosidl derives).
    pub fn resolve_service(&self, name: &str) -> Option<Result<ResolvedService, Error>> {
        Some(
            self.resolve_service_type(name)?
                .and_then(|ty| ResolvedService::of_type(&ty)),
        )
    }

    /// [`resolve_service`](Self::resolve_service), the service as one
    /// run-time type: its own description with its request, response and
    /// event, as a server of it describes it to other nodes.
    pub fn resolve_service_type(&self, name: &str) -> Option<Result<DynamicType, Error>> {
        let service = self.services.get(name)?;
        // The service's own description, as rosidl states it: one nested
        // field for each message of a call.
        let own = [
            ("request_message", &service.request),
            ("response_message", &service.response),
            ("event_message", &service.event),
        ]
        .map(|(field, message)| DescribedFieldBuf {
            name: field.to_owned(),
            type_id: TypeId::Nested as u8,
            capacity: 0,
            string_capacity: 0,
            nested_type_name: message.ty.full_name(),
            default_value: String::new(),
        })
        .to_vec();
        let sources = service
            .source
            .iter()
            .map(|text| (name.to_owned(), text.clone()))
            .collect();
        let built = self.build(name, BTreeMap::from([(name.to_owned(), own)]), sources);
        Some(built.map(|resolved| resolved.ty))
    }

    /// The run-time type `name` of the files (or of `described`, given
    /// already), with every type it uses.
    fn build(
        &self,
        name: &str,
        mut described: BTreeMap<String, Vec<DescribedFieldBuf>>,
        mut sources: BTreeMap<String, String>,
    ) -> Result<ResolvedType, Error> {
        let mut todo: Vec<String> = match described.get(name) {
            Some(own) => own
                .iter()
                .filter(|f| !f.nested_type_name.is_empty())
                .map(|f| f.nested_type_name.clone())
                .collect(),
            None => vec![name.to_owned()],
        };
        while let Some(next) = todo.pop() {
            if described.contains_key(&next) {
                continue;
            }
            if let Some(message) = self.messages.get(&next) {
                for field in &message.fields {
                    if let BaseType::Message(r) = &field.ty.base {
                        todo.push(r.full_name());
                    }
                }
                described.insert(next.clone(), message.described_fields());
                if let Some(text) = &message.source {
                    sources.insert(next, text.clone());
                }
                continue;
            }
            let known = standard()
                .get(next.as_str())
                .filter(|k| k.kind == Kind::Message)
                .ok_or_else(|| {
                    format!(
                        "{name} uses {next}, which is neither in the interface files nor a standard message"
                    )
                })?;
            let description = (known.describe)();
            for (type_name, _, text) in description.sources() {
                sources.insert(type_name.to_owned(), text.into_owned());
            }
            for d in std::iter::once(&description.own).chain(&description.referenced) {
                described.entry(d.type_name.to_owned()).or_insert_with(|| {
                    d.fields
                        .iter()
                        .map(|f| DescribedField::of(f).into())
                        .collect()
                });
            }
        }
        let own = described
            .get(name)
            .ok_or_else(|| format!("{name}: not described"))?;
        let referenced = described.iter().filter(|(n, _)| n.as_str() != name);
        let ty = DynamicType::from_described(
            std::iter::once((name, own))
                .chain(referenced.map(|(n, fields)| (n.as_str(), fields)))
                .map(|(n, fields)| (n, fields.iter().map(DescribedFieldBuf::as_described))),
            &TypeLimits::DEFAULT,
        )?;
        let definition = definition::of_dynamic(&ty, |n| sources.get(n).cloned());
        Ok(ResolvedType { ty, definition })
    }
}

fn is_package(dir: &Path) -> bool {
    ["msg", "srv", "action"]
        .iter()
        .any(|s| dir.join(s).is_dir())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every standard interface written back to its file (`.msg`, `.srv`,
    /// `.action`, from the text rosidl keeps) and read from there gives every
    /// message type, service part and action part its compiled hash.
    #[test]
    fn every_standard_interface_read_from_its_file_has_its_hash() {
        let root = std::env::temp_dir().join(format!("shm_types_local_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        for (name, known) in standard() {
            let description = (known.describe)();
            let (encoding, text) = description.own.source_text();
            let Some(&[pkg, kind, file]) = name.split('/').collect::<Vec<_>>().get(..3) else {
                continue;
            };
            if encoding == "implicit" {
                continue; // a type rosidl derives from a service or action file
            }
            assert_eq!(encoding, kind, "{name}");
            let dir = root.join(pkg).join(kind);
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(dir.join(format!("{file}.{kind}")), text.as_ref()).unwrap();
        }
        let local = LocalInterfaces::load(std::slice::from_ref(&root)).unwrap();
        let mut checked = 0;
        for (name, known) in standard() {
            let compiled = DynamicType::from_description(&(known.describe)()).unwrap();
            for part in compiled.structs() {
                let Some(from_files) = local.resolve(&part.name) else {
                    // A service or action type itself: not a message.
                    let kind = standard().get(part.name.as_str()).map(|k| k.kind);
                    assert!(
                        matches!(kind, Some(Kind::Service | Kind::Action)),
                        "{}",
                        part.name
                    );
                    continue;
                };
                let from_files = from_files.unwrap();
                let expected = compiled.member(&part.name).unwrap().type_hash();
                assert_eq!(
                    from_files.ty.type_hash(),
                    expected,
                    "{} (of {name})",
                    part.name
                );
                checked += 1;
            }
        }
        assert!(checked > 500, "{checked}");
        // Each service read from its `.srv` file has the service's compiled
        // hash, which covers its request, response and event.
        let mut services = 0;
        for (name, known) in standard().iter().filter(|(_, k)| k.kind == Kind::Service) {
            let description = (known.describe)();
            let Some(from_file) = local.resolve_service(name) else {
                panic!("{name}: not read from its file");
            };
            let from_file = from_file.unwrap();
            assert_eq!(from_file.hash, description.type_hash(), "{name}");
            assert_eq!(from_file.name, *name);
            assert_eq!(from_file.request.name(), format!("{name}_Request"));
            let compiled = DynamicType::from_description(&description).unwrap();
            let request = compiled.member(&format!("{name}_Request")).unwrap();
            assert_eq!(from_file.request.type_hash(), request.type_hash(), "{name}");
            services += 1;
        }
        assert!(services > 40, "{services}");
        assert!(local.resolve_service("std_msgs/msg/String").is_none());
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn a_type_using_one_found_nowhere_says_which() {
        let root = std::env::temp_dir().join(format!("shm_types_local_bad_{}", std::process::id()));
        let dir = root.join("robot_msgs").join("msg");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("Arm.msg"),
            "robot_msgs/Joint[] joints\nfloat64 reach 1.5\n",
        )
        .unwrap();
        let local = LocalInterfaces::load(&[root.join("robot_msgs")]).unwrap();
        let err = local.resolve("robot_msgs/msg/Arm").unwrap().unwrap_err();
        assert!(
            err.to_string().contains("uses robot_msgs/msg/Joint"),
            "{err}"
        );
        assert!(local.resolve("robot_msgs/msg/Nothing").is_none());
        let _ = std::fs::remove_dir_all(&root);
    }
}
