//! The standard interfaces (`shm_cdr::msgs`), by name, as each
//! distribution defines them: the first place a type is looked for, before
//! interface files and the nodes that announce it.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use crate::rmw::{Distro, TYPE_HASH_NOT_SUPPORTED};
use shm_cdr::describe::FullDescription;
use shm_cdr::dynamic::DynamicType;
use shm_cdr::{RosAction, RosMessage, RosService};

use super::definition;

/// Which kind of interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `pkg/msg/Name`.
    Message,
    /// `pkg/srv/Name`.
    Service,
    /// `pkg/action/Name`.
    Action,
}

/// What the binary knows of a standard interface.
pub struct Known {
    /// Message, service or action.
    pub kind: Kind,
    /// Its RIHS01 hash.
    pub hash: &'static str,
    /// Its full description (the type and every type it uses).
    pub describe: fn() -> FullDescription,
}

/// Every standard message, service and action type, by name.
pub fn standard() -> &'static BTreeMap<&'static str, Known> {
    static TABLE: OnceLock<BTreeMap<&'static str, Known>> = OnceLock::new();
    TABLE.get_or_init(|| {
        macro_rules! table {
            (
                messages: [$($m:ty),* $(,)?],
                borrowed: [$(($o:ty, $r:ty)),* $(,)?],
                services: [$($s:ty),* $(,)?],
                actions: [$($a:ty),* $(,)?],
            ) => {{
                let mut out = BTreeMap::new();
                $( out.insert(<$m as RosMessage>::TYPE_NAME, Known {
                    kind: Kind::Message,
                    hash: <$m as RosMessage>::type_hash(),
                    describe: <$m as RosMessage>::full_description,
                }); )*
                // A service's events (introspection) are messages on a topic.
                $( out.insert(<<$s as RosService>::Event as RosMessage>::TYPE_NAME, Known {
                    kind: Kind::Message,
                    hash: <<$s as RosService>::Event as RosMessage>::type_hash(),
                    describe: <<$s as RosService>::Event as RosMessage>::full_description,
                }); )*
                $( out.insert(<$s as RosService>::TYPE_NAME, Known {
                    kind: Kind::Service,
                    hash: <$s as RosService>::type_hash(),
                    describe: <$s as RosService>::full_description,
                }); )*
                $( out.insert(<$a as RosAction>::TYPE_NAME, Known {
                    kind: Kind::Action,
                    hash: <$a as RosAction>::type_hash(),
                    describe: <$a as RosAction>::full_description,
                }); )*
                out
            }};
        }
        shm_cdr::for_each_interface!(table)
    })
}

/// The standard messages a distribution defines differently from the
/// [`standard`] set ([`shm_cdr::distro_msgs`]), with the distributions that
/// use each.
fn distro_messages() -> &'static [(Vec<Distro>, Known, &'static str)] {
    static TABLE: OnceLock<Vec<(Vec<Distro>, Known, &'static str)>> = OnceLock::new();
    TABLE.get_or_init(|| {
        shm_cdr::distro_msgs::variants()
            .into_iter()
            .map(|v| {
                let distros = v.distros.iter().filter_map(|d| d.parse().ok()).collect();
                let known = Known {
                    kind: Kind::Message,
                    hash: v.type_hash,
                    describe: v.describe,
                };
                (distros, known, v.type_name)
            })
            .collect()
    })
}

/// The standard message `name` (`pkg/msg/Name`) as `distro` defines it.
pub(crate) fn standard_message_in(name: &str, distro: Distro) -> Option<&'static Known> {
    distro_messages()
        .iter()
        .find(|(distros, _, n)| *n == name && distros.contains(&distro))
        .map(|(_, known, _)| known)
        .or_else(|| standard().get(name).filter(|k| k.kind == Kind::Message))
}

/// The standard message `name` whose definition an endpoint announcing
/// `hash` uses: by its hash in any distribution, or on Humble (which has no
/// hashes) by name as Humble defines it.
pub(crate) fn standard_message_announced(name: &str, hash: &str) -> Option<&'static Known> {
    if hash == TYPE_HASH_NOT_SUPPORTED {
        return standard_message_in(name, Distro::Humble);
    }
    distro_messages()
        .iter()
        .find(|(_, known, n)| *n == name && known.hash == hash)
        .map(|(_, known, _)| known)
        .or_else(|| {
            standard()
                .get(name)
                .filter(|k| k.kind == Kind::Message && k.hash == hash)
        })
}

/// `pkg/msg/Name` from what users write: `pkg/msg/Name` or `pkg/Name`.
pub fn full_name(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts[..] {
        [pkg, ty] => format!("{pkg}/msg/{ty}"),
        _ => name.to_owned(),
    }
}

/// A message type resolved for a topic: the run-time type and its complete
/// definition in rosbag2's `ros2msg` form.
#[derive(Debug, Clone)]
pub struct ResolvedType {
    /// The run-time type (its name and RIHS01 hash are the announced ones).
    pub ty: DynamicType,
    /// The `.msg` text of the type and, after rosbag2's delimiters, of every
    /// type it uses (see [`definition`]).
    pub definition: String,
}

/// A standard interface by name (`pkg/msg/Name`, `pkg/srv/Name`,
/// `pkg/action/Name`), as `distro` defines it and words its files.
pub fn standard_description(name: &str, distro: Distro) -> Option<(Kind, FullDescription)> {
    let known = standard_message_in(name, distro).or_else(|| standard().get(name))?;
    let description = shm_cdr::distro_msgs::with_sources_of(distro.name(), (known.describe)());
    Some((known.kind, description))
}

/// A standard message type by name (`pkg/msg/Name` or `pkg/Name`), as
/// `distro` defines it.
pub fn standard_message(name: &str, distro: Distro) -> Option<ResolvedType> {
    let (_, description) = standard_description(&full_name(name), distro)
        .filter(|(kind, _)| *kind == Kind::Message)?;
    let ty = DynamicType::from_description(&description).ok()?;
    Some(ResolvedType {
        ty,
        definition: definition::of_description(&description),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fields(known: &Known) -> Vec<String> {
        let ty = DynamicType::from_description(&(known.describe)()).unwrap();
        ty.root().fields.iter().map(|f| f.name.clone()).collect()
    }

    #[test]
    fn every_variant_names_distributions_this_crate_speaks() {
        for variant in shm_cdr::distro_msgs::variants() {
            for name in variant.distros {
                assert!(name.parse::<Distro>().is_ok(), "{name}");
            }
        }
        assert_eq!(
            distro_messages().len(),
            shm_cdr::distro_msgs::variants().len()
        );
    }

    #[test]
    fn each_distribution_gets_its_definition() {
        let range = "sensor_msgs/msg/Range";
        let humble = standard_message_in(range, Distro::Humble).unwrap();
        assert!(!fields(humble).contains(&"variance".to_owned()));
        for distro in [
            Distro::Jazzy,
            Distro::Kilted,
            Distro::Lyrical,
            Distro::Rolling,
        ] {
            let known = standard_message_in(range, distro).unwrap();
            assert!(fields(known).contains(&"variance".to_owned()), "{distro}");
        }
        // Humble has no hashes: its topics resolve by name.
        let announced = standard_message_announced(range, TYPE_HASH_NOT_SUPPORTED).unwrap();
        assert_eq!(announced.hash, humble.hash);

        // Elsewhere the hash picks the definition, whichever distribution.
        let event = "lifecycle_msgs/msg/TransitionEvent";
        let lyrical = standard_message_in(event, Distro::Lyrical).unwrap();
        let kilted = standard_message_in(event, Distro::Kilted).unwrap();
        assert_ne!(lyrical.hash, kilted.hash);
        assert_eq!(fields(lyrical)[0], "stamp");
        assert_eq!(fields(kilted)[0], "timestamp");
        for known in [lyrical, kilted] {
            let found = standard_message_announced(event, known.hash).unwrap();
            assert_eq!(found.hash, known.hash);
        }
        assert!(standard_message_announced(event, "RIHS01_00").is_none());
    }
}
