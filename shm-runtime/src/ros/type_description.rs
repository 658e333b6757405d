//! A node's `~/get_type_description` service
//! (`type_description_interfaces/srv/GetTypeDescription`), as rcl serves it: the
//! full description of every type the node's publishers, subscribers, services
//! and clients use, looked up by type hash, with the interface files' text on
//! request.
//!
//! Compiled types come from the one description the derive and the code
//! generator emit
//! ([`RosMessage::full_description`](shm_cdr::RosMessage::full_description)),
//! types known at run time from their [`DynamicType`], so the hash in a reply
//! is the one in the node's liveliness tokens.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard, Weak};

use shm_cdr::describe::FullDescription;
use shm_cdr::dynamic::DynamicType;

use crate::ros::topic_types::TopicUse;
use crate::transport::type_registration::{Registered, TypeRegistration};
use shm_cdr::msgs::type_description_interfaces::msg as td;
use shm_cdr::msgs::type_description_interfaces::srv::{
    GetTypeDescription_Request, GetTypeDescription_Response,
};

/// Why a request fails, in rcl's words.
const UNPARSABLE_HASH: &str = "Failed to parse type hash";
const NOT_IN_USE: &str = "Type not currently in use by this node";

/// The types a node uses, by hash, each counted by the entities using it.
#[derive(Default)]
pub(crate) struct TypeCache {
    entries: Mutex<HashMap<String, Entry>>,
    /// Whose wording of the interface files the sources carry.
    distro: crate::rmw::Distro,
}

struct Entry {
    uses: usize,
    described: Described,
}

/// What the node answers for one type: its description and the text of each
/// interface file it uses.
pub(crate) struct Described {
    description: td::TypeDescription,
    sources: Vec<td::TypeSource>,
    /// Whether `sources` were written back from the description (a type known
    /// at run time), so that the files' own text, offered later, replaces
    /// them.
    written_back: bool,
}

impl Described {
    fn of_full(description: &FullDescription) -> Self {
        Self {
            description: description.into(),
            sources: description
                .sources()
                .map(|(type_name, encoding, text)| td::TypeSource {
                    type_name: type_name.to_owned(),
                    encoding: encoding.to_owned(),
                    raw_file_contents: text.into_owned(),
                })
                .collect(),
            written_back: false,
        }
    }

    fn of_dynamic(ty: &DynamicType) -> Self {
        Self {
            description: ty.to_type_description_msg(),
            sources: ty
                .msg_texts()
                .into_iter()
                .map(|(type_name, text)| td::TypeSource {
                    type_name: type_name.to_owned(),
                    encoding: "msg".to_owned(),
                    raw_file_contents: text,
                })
                .collect(),
            written_back: true,
        }
    }
}

impl TypeCache {
    /// An empty cache whose sources are the interface files as released for
    /// `distro`.
    pub(crate) fn of(distro: crate::rmw::Distro) -> Self {
        Self {
            entries: Mutex::default(),
            distro,
        }
    }

    fn entries(&self) -> MutexGuard<'_, HashMap<String, Entry>> {
        // The map is whole between statements.
        self.entries.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Count one more use of the type with hash `hash`; `describe` is called only
    /// for a type not yet in use. The type leaves the cache when the last
    /// returned [`TypeUse`] is dropped.
    pub(crate) fn register(
        self: &Arc<Self>,
        hash: &str,
        describe: impl FnOnce() -> FullDescription,
    ) -> TypeUse {
        let distro = self.distro.name();
        self.register_described(hash, || {
            Described::of_full(&shm_cdr::distro_msgs::with_sources_of(distro, describe()))
        })
    }

    /// Count one more use of the run-time type `ty`, described as
    /// [`DynamicType::to_type_description_msg`] gives it, with `.msg` text
    /// written back from it until [`TypeUse::offer_sources`] gives the files'.
    pub(crate) fn register_dynamic(self: &Arc<Self>, ty: &DynamicType) -> TypeUse {
        self.register_described(&ty.type_hash(), || Described::of_dynamic(ty))
    }

    fn register_described(
        self: &Arc<Self>,
        hash: &str,
        describe: impl FnOnce() -> Described,
    ) -> TypeUse {
        let mut entries = self.entries();
        entries
            .entry(hash.to_owned())
            .and_modify(|e| e.uses += 1)
            .or_insert_with(|| Entry {
                uses: 1,
                described: describe(),
            });
        TypeUse {
            _registration: Arc::new(Registration {
                cache: Arc::downgrade(self),
                hash: hash.to_owned(),
            }),
            _topic: None,
        }
    }

    fn unregister(&self, hash: &str) {
        let mut entries = self.entries();
        if let Some(entry) = entries.get_mut(hash) {
            entry.uses -= 1;
            if entry.uses == 0 {
                entries.remove(hash);
            }
        }
    }

    /// The reply rcl gives: found by hash alone (the request's type name is not
    /// consulted), sources only when asked for.
    pub(crate) fn answer(
        &self,
        request: &GetTypeDescription_Request,
    ) -> GetTypeDescription_Response {
        let failure = |reason: &str| GetTypeDescription_Response {
            failure_reason: reason.to_owned(),
            ..GetTypeDescription_Response::default()
        };
        let Some(hash) = parse_rihs01(&request.type_hash) else {
            return failure(UNPARSABLE_HASH);
        };
        let entries = self.entries();
        let Some(entry) = entries.get(&hash) else {
            return failure(NOT_IN_USE);
        };
        GetTypeDescription_Response {
            successful: true,
            type_description: entry.described.description.clone(),
            type_sources: if request.include_type_sources {
                entry.described.sources.clone()
            } else {
                Vec::new()
            },
            ..GetTypeDescription_Response::default()
        }
    }

    /// Replace the written-back text of the types named in `sources` with
    /// the text given, for the type with hash `hash`.
    fn offer_sources(&self, hash: &str, sources: &[(String, String)]) {
        let mut entries = self.entries();
        let Some(entry) = entries.get_mut(hash) else {
            return;
        };
        if !entry.described.written_back {
            return;
        }
        for source in &mut entry.described.sources {
            if let Some((_, text)) = sources.iter().find(|(name, _)| *name == source.type_name) {
                source.raw_file_contents.clone_from(text);
            }
        }
    }
}

/// One entity's use of a type in its node's [`TypeCache`] (and, for a topic's
/// endpoint, of the topic with that type: see [`crate::ros::topic_types`]); the entity
/// holds it while it lives.
#[derive(Clone)]
pub(crate) struct TypeUse {
    _registration: Arc<Registration>,
    _topic: Option<Arc<TopicUse>>,
}

/// A compiled type keeps the text it was built with; a type known at run
/// time takes the offered text in place of the text written back from its
/// description.
impl TypeRegistration for TypeUse {
    fn offer_sources(&self, sources: &[(String, String)]) {
        if let Some(cache) = self._registration.cache.upgrade() {
            cache.offer_sources(&self._registration.hash, sources);
        }
    }
}

impl TypeUse {
    /// This use, for an endpoint of the transport to hold.
    pub(crate) fn registered(self) -> Registered {
        Arc::new(self)
    }

    /// The same use, holding `topic` too.
    pub(crate) fn with_topic(self, topic: TopicUse) -> Self {
        Self {
            _topic: Some(Arc::new(topic)),
            ..self
        }
    }
}

struct Registration {
    cache: Weak<TypeCache>,
    hash: String,
}

impl Drop for Registration {
    fn drop(&mut self) {
        if let Some(cache) = self.cache.upgrade() {
            cache.unregister(&self.hash);
        }
    }
}

/// The hash in the lowercase form our tokens use, if `text` is a RIHS01 hash as
/// rosidl parses one: `RIHS`, version `01` in hex, then 64 hex digits at
/// offset 7, 71 characters in all.
fn parse_rihs01(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let version = bytes.get(4..6)?;
    let valid = bytes.len() == 71
        && bytes.starts_with(b"RIHS")
        && version.eq_ignore_ascii_case(b"01")
        && bytes.get(7..)?.iter().all(u8::is_ascii_hexdigit);
    if !valid {
        return None;
    }
    Some(format!("RIHS01_{}", text.get(7..)?.to_ascii_lowercase()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_cdr::msgs::rcl_interfaces::msg::Log;
    use shm_cdr::RosMessage;

    fn ask(cache: &TypeCache, hash: &str, sources: bool) -> GetTypeDescription_Response {
        cache.answer(&GetTypeDescription_Request {
            type_name: String::new(),
            type_hash: hash.to_owned(),
            include_type_sources: sources,
        })
    }

    #[test]
    fn a_type_is_answered_while_something_uses_it() {
        let cache = Arc::new(TypeCache::default());
        let first = cache.register(Log::type_hash(), Log::full_description);
        let second = cache.register(Log::type_hash(), || unreachable!("described once"));
        // rosidl reads hex digits of either case.
        let reply = ask(&cache, &Log::type_hash().to_ascii_uppercase(), true);
        assert!(reply.successful, "{}", reply.failure_reason);
        assert_eq!(
            reply.type_description.type_description.type_name.as_str(),
            Log::TYPE_NAME
        );
        assert_eq!(reply.type_description.referenced_type_descriptions.len(), 1);
        assert_eq!(reply.type_sources.len(), 2);
        assert_eq!(reply.type_sources[0].encoding, "msg");
        assert!(ask(&cache, Log::type_hash(), false).type_sources.is_empty());
        drop(first);
        assert!(ask(&cache, Log::type_hash(), false).successful);
        drop(second);
        let gone = ask(&cache, Log::type_hash(), false);
        assert!(!gone.successful);
        assert_eq!(gone.failure_reason, NOT_IN_USE);
    }

    #[test]
    fn hashes_parse_as_rosidl_parses_them() {
        let hash = Log::type_hash();
        assert_eq!(parse_rihs01(hash).as_deref(), Some(hash));
        assert!(parse_rihs01(&hash[..70]).is_none());
        assert!(parse_rihs01(&hash.replace("RIHS01", "RIHS02")).is_none());
        assert!(parse_rihs01(&format!("{}g", &hash[..70])).is_none());
        assert!(parse_rihs01("").is_none());
        assert!(parse_rihs01("RIHS01_é").is_none());
        let cache = TypeCache::default();
        assert_eq!(
            ask(&cache, "RIHS01_00", true).failure_reason,
            UNPARSABLE_HASH
        );
    }
}
