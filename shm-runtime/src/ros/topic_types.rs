//! Endpoints of another type on a node's topics. A publisher and a subscriber
//! exchange messages only if their type names and hashes are equal (both are
//! part of the key expression), so a peer whose definition differs (another
//! distribution, another version of a package, another type altogether) is
//! silently never heard. The node follows its graph for such endpoints on the
//! topics it uses, warns once for each, and lists them
//! ([`RosNode::topic_type_conflicts`](crate::RosNode::topic_type_conflicts)).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard, Weak};

use crate::rmw::{Distro, EntityKind, TYPE_HASH_NOT_SUPPORTED};
use crate::ros::graph::{Entity, GraphCache, GraphCallback, GraphEvent};

/// At most this many conflicts are kept and warned about per node: a peer
/// announcing endless types cannot grow the table.
const MAX_CONFLICTS: usize = 256;

/// An endpoint on one of this node's topics whose type differs from the type
/// this node uses there: the two never exchange messages.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TypeConflict {
    /// The topic, fully qualified.
    pub topic: String,
    /// The type name and hash this node's endpoints on the topic use (the
    /// first, if they use several).
    pub ours: (String, String),
    /// The other endpoint's type name and hash.
    pub theirs: (String, String),
    /// Whether the other endpoint publishes or subscribes.
    pub kind: EntityKind,
    /// The other endpoint's node, fully qualified.
    pub node: String,
}

struct Shared {
    /// Per topic, the (type name, hash) of each of this node's endpoints.
    ours: Mutex<HashMap<String, Vec<(String, String)>>>,
    conflicts: Mutex<Vec<TypeConflict>>,
    distro: Distro,
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // Each entry is written whole.
    mutex.lock().unwrap_or_else(|e| e.into_inner())
}

/// The topics a node uses and the conflicts seen on them.
pub(crate) struct TopicTypes {
    shared: Arc<Shared>,
    /// Following the graph from the first topic on.
    watch: Mutex<Option<Arc<Watch>>>,
}

/// The type checks of the nodes that share one graph cache (a session's
/// domain), fed by one graph callback: a callback, and its thread, per node
/// would wake every node of a process at every change of the graph.
struct Watch {
    cache: GraphCache,
    nodes: Arc<Mutex<Vec<Weak<Shared>>>>,
    _callback: GraphCallback,
}

/// The watch of each graph cache some node follows.
static WATCHES: Mutex<Vec<Weak<Watch>>> = Mutex::new(Vec::new());

impl Watch {
    /// The watch of `graph`: the one its nodes share, or a new one.
    fn of(graph: &GraphCache) -> zenoh::Result<Arc<Watch>> {
        let mut watches = lock(&WATCHES);
        if let Some(watch) = watches
            .iter()
            .filter_map(Weak::upgrade)
            .find(|w| w.cache.is(graph))
        {
            return Ok(watch);
        }
        watches.retain(|w| w.strong_count() > 0);
        let nodes: Arc<Mutex<Vec<Weak<Shared>>>> = Arc::default();
        let on_change = nodes.clone();
        let cache = graph.clone();
        let callback = graph.on_change(move |event| {
            let mut nodes = lock(&on_change);
            nodes.retain(|node| node.strong_count() > 0);
            for node in nodes.iter().filter_map(Weak::upgrade) {
                match &event {
                    GraphEvent::Appeared(entity) => node.check(entity),
                    // Changes were dropped from the queue: look at it all.
                    GraphEvent::Missed => node.check_all(&cache),
                    GraphEvent::Left(_) => {}
                }
            }
        })?;
        let watch = Arc::new(Watch {
            cache: graph.clone(),
            nodes,
            _callback: callback,
        });
        watches.push(Arc::downgrade(&watch));
        Ok(watch)
    }
}

impl TopicTypes {
    pub(crate) fn new(distro: Distro) -> Self {
        Self {
            shared: Arc::new(Shared {
                ours: Mutex::default(),
                conflicts: Mutex::default(),
                distro,
            }),
            watch: Mutex::default(),
        }
    }

    /// Follow `topic` while the returned use lives, for as long as an
    /// endpoint of this node uses it with `type_name` and `type_hash`. The
    /// graph is followed from the first call on; if it cannot be, the node
    /// works on without the warning (and says so).
    pub(crate) fn watch(
        &self,
        graph: zenoh::Result<GraphCache>,
        topic: &str,
        type_name: &str,
        type_hash: &str,
    ) -> TopicUse {
        let entry = (type_name.to_owned(), type_hash.to_owned());
        lock(&self.shared.ours)
            .entry(topic.to_owned())
            .or_default()
            .push(entry.clone());
        let graph = match graph {
            Ok(graph) => Some(graph),
            Err(e) => {
                tracing::debug!(topic, "endpoints of other types are not looked for: {e}");
                None
            }
        };
        if let Some(graph) = graph {
            let mut watch = lock(&self.watch);
            if watch.is_none() {
                match Watch::of(&graph) {
                    Ok(shared_watch) => {
                        lock(&shared_watch.nodes).push(Arc::downgrade(&self.shared));
                        *watch = Some(shared_watch);
                    }
                    Err(e) => tracing::debug!("endpoints of other types are not looked for: {e}"),
                }
            }
            drop(watch);
            // What is there already (a change after this is seen by the
            // callback too; a conflict is kept once).
            self.shared.check_topic(&graph, topic);
        }
        TopicUse {
            shared: self.shared.clone(),
            topic: topic.to_owned(),
            entry,
        }
    }

    pub(crate) fn conflicts(&self) -> Vec<TypeConflict> {
        lock(&self.shared.conflicts).clone()
    }
}

impl Shared {
    fn check_topic(&self, graph: &GraphCache, topic: &str) {
        let endpoints = {
            let graph = graph.read();
            let mut endpoints = graph.endpoints(EntityKind::Publisher, topic);
            endpoints.extend(graph.endpoints(EntityKind::Subscriber, topic));
            endpoints
        };
        for entity in endpoints {
            self.check(&entity);
        }
    }

    fn check_all(&self, graph: &GraphCache) {
        let topics: Vec<String> = lock(&self.ours).keys().cloned().collect();
        for topic in topics {
            self.check_topic(graph, &topic);
        }
    }

    fn check(&self, entity: &Entity) {
        let Some(endpoint) = entity.endpoint.as_ref() else {
            return;
        };
        if !matches!(entity.kind, EntityKind::Publisher | EntityKind::Subscriber) {
            return;
        }
        let ours = {
            let ours = lock(&self.ours);
            let Some(types) = ours.get(&endpoint.name) else {
                return;
            };
            let theirs = (endpoint.type_name.clone(), endpoint.type_hash.clone());
            if types.contains(&theirs) {
                return;
            }
            match types.first() {
                Some(first) => first.clone(),
                None => return,
            }
        };
        let conflict = TypeConflict {
            topic: endpoint.name.clone(),
            ours,
            theirs: (endpoint.type_name.clone(), endpoint.type_hash.clone()),
            kind: entity.kind,
            node: entity.node_fqn(),
        };
        {
            let mut conflicts = lock(&self.conflicts);
            let known = conflicts
                .iter()
                .any(|c| c.topic == conflict.topic && c.theirs == conflict.theirs);
            if known || conflicts.len() >= MAX_CONFLICTS {
                return;
            }
            conflicts.push(conflict.clone());
        }
        self.warn(&conflict);
    }

    fn warn(&self, c: &TypeConflict) {
        let role = match c.kind {
            EntityKind::Publisher => "publisher",
            _ => "subscriber",
        };
        let speaks = self.distro.name();
        if c.ours.0 != c.theirs.0 {
            tracing::warn!(
                topic = %c.topic,
                "a {role} of node {} on {} uses {}, where this node uses {}: they never exchange messages",
                c.node, c.topic, c.theirs.0, c.ours.0
            );
        } else if c.ours.1 == TYPE_HASH_NOT_SUPPORTED || c.theirs.1 == TYPE_HASH_NOT_SUPPORTED {
            tracing::warn!(
                topic = %c.topic,
                "a {role} of node {} on {} announces {} with type hash {:?}, this node {:?}: one of them speaks Humble \
                 (no type hashes) and the other does not, so they never exchange messages. This node speaks {speaks}: \
                 set ROS_DISTRO (or RosNodeBuilder::distro) to the other side's distribution",
                c.node, c.topic, c.theirs.0, c.theirs.1, c.ours.1
            );
        } else {
            tracing::warn!(
                topic = %c.topic,
                "a {role} of node {} on {} uses another definition of {} (type hash {}, this node's {}): \
                 they never exchange messages. Another ROS 2 distribution (this node speaks {speaks}: ROS_DISTRO or \
                 RosNodeBuilder::distro) or another version of the package defines it",
                c.node, c.topic, c.theirs.0, c.theirs.1, c.ours.1
            );
        }
    }
}

/// One endpoint's use of a topic with its type; the endpoint holds it while
/// it lives.
pub(crate) struct TopicUse {
    shared: Arc<Shared>,
    topic: String,
    entry: (String, String),
}

impl Drop for TopicUse {
    fn drop(&mut self) {
        let mut ours = lock(&self.shared.ours);
        if let Some(types) = ours.get_mut(&self.topic) {
            if let Some(at) = types.iter().position(|t| *t == self.entry) {
                types.swap_remove(at);
            }
            if types.is_empty() {
                ours.remove(&self.topic);
            }
        }
    }
}
