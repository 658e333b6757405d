//! rmw_zenoh_cpp naming, so ROS 2 nodes using rmw_zenoh talk to us: data key
//! expressions, the per-sample attachment, liveliness tokens and GIDs.

use std::fmt;
use std::time::Duration;

use shm_cdr::interface::RosService;
use shm_cdr::RosMessage;

pub mod config;
mod distro;
mod topic_type;
pub use distro::{Distribution, Distro, UnknownDistro, DISTRIBUTIONS, TYPE_HASH_NOT_SUPPORTED};
pub(crate) use topic_type::TopicType;

/// The data key expression of a topic, as `distro`'s rmw_zenoh_cpp writes it:
/// `<domain>/<topic without leading/trailing '/'>/<pkg>::msg::dds_::<Name>_/<RIHS01 hash>`
/// (`TypeHashNotSupported` in place of the hash on Humble).
pub fn topic_key_expr<T: RosMessage>(distro: Distro, domain_id: u32, topic: &str) -> String {
    data_key_expr(distro, domain_id, topic, T::DDS_TYPE_NAME, T::type_hash())
}

/// [`topic_key_expr`] of a type given at run time.
pub(crate) fn topic_key_expr_of(
    distro: Distro,
    domain_id: u32,
    topic: &str,
    ty: &TopicType,
) -> String {
    data_key_expr(distro, domain_id, topic, &ty.dds_name(), &ty.hash)
}

/// The key expression of a service, which its server's queryable declares and its
/// clients query: `<domain>/<service name without leading/trailing '/'>/<pkg>::srv::dds_::<Name>_/<RIHS01 hash of the service>`
/// (`TypeHashNotSupported` in place of the hash on Humble).
pub fn service_key_expr<S: RosService>(distro: Distro, domain_id: u32, service: &str) -> String {
    data_key_expr(distro, domain_id, service, S::DDS_TYPE_NAME, S::type_hash())
}

fn data_key_expr(
    distro: Distro,
    domain_id: u32,
    name: &str,
    dds_type_name: &str,
    type_hash: &str,
) -> String {
    format!(
        "{domain_id}/{}/{dds_type_name}/{}",
        name.trim_matches('/'),
        distro.hash_field(type_hash)
    )
}

/// The key on which a buffer-aware publisher of Lyrical's or Rolling's
/// rmw_zenoh_cpp sends a subscriber its messages, for a subscriber of a type
/// with a `uint8[]` field of its own (a `rosidl::Buffer` in C++ code
/// generated on those distributions) on `key_expr`, whose token is `token`:
/// `<key_expr>/_buf/<the subscriber's GID in lower-case hex>`; `None` for
/// other types and distributions.
///
/// Such a publisher (volatile) counts the subscribers it has discovered
/// with it, ours included, and while they are all it has matched it sends
/// each message to each one on its own key instead of the topic's key
/// (0.10.5 `PublisherData::publish` and `on_subscriber_discovered`,
/// `buffer_endpoint_helpers.hpp`). A subscriber that announces no buffer
/// backends gets a plain CDR message there: a buffer in CPU memory is
/// serialized as the `uint8[]` it stands for (`buffer_serialization.hpp` of
/// rosidl_typesupport_fastrtps).
pub fn buffer_key_expr(
    distro: Distro,
    key_expr: &str,
    token: &str,
    has_buffer_fields: bool,
) -> Option<String> {
    if !(distro.has_buffer_aware_endpoints() && has_buffer_fields) {
        return None;
    }
    let gid = Gid::from_token(token);
    Some(format!("{key_expr}/_buf/{gid:?}"))
}

/// The 33-byte attachment rmw_zenoh_cpp puts on every sample, request and reply
/// (a reply carries its request's sequence number and client GID).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attachment {
    /// Per-publisher sequence number, from 1.
    pub sequence_number: i64,
    /// Source timestamp in nanoseconds since the Unix epoch.
    pub source_timestamp: i64,
    /// The publisher's GID.
    pub gid: Gid,
}

/// Length of an encoded [`Attachment`].
pub const ATTACHMENT_LEN: usize = 33;

impl Attachment {
    /// `seq` (i64 LE), `timestamp` (i64 LE), `0x10` (the GID length as LEB128), GID.
    #[inline]
    pub fn to_bytes(&self) -> [u8; ATTACHMENT_LEN] {
        let mut out = [0u8; ATTACHMENT_LEN];
        out[..8].copy_from_slice(&self.sequence_number.to_le_bytes());
        out[8..16].copy_from_slice(&self.source_timestamp.to_le_bytes());
        out[16] = 16;
        out[17..].copy_from_slice(&self.gid.0);
        out
    }

    /// Parse an attachment; a wrong length or GID size is an error.
    pub fn parse(bytes: &[u8]) -> Result<Self, AttachmentError> {
        let Ok(bytes) = <&[u8; ATTACHMENT_LEN]>::try_from(bytes) else {
            return Err(AttachmentError::Length(bytes.len()));
        };
        if bytes[16] != 16 {
            return Err(AttachmentError::GidLength(bytes[16]));
        }
        let mut seq = [0u8; 8];
        seq.copy_from_slice(&bytes[..8]);
        let mut ts = [0u8; 8];
        ts.copy_from_slice(&bytes[8..16]);
        let mut gid = [0u8; 16];
        gid.copy_from_slice(&bytes[17..]);
        Ok(Self {
            sequence_number: i64::from_le_bytes(seq),
            source_timestamp: i64::from_le_bytes(ts),
            gid: Gid(gid),
        })
    }
}

/// An attachment that is not rmw_zenoh_cpp's.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum AttachmentError {
    /// Not 33 bytes long.
    Length(usize),
    /// The GID length byte is not 16.
    GidLength(u8),
}

impl fmt::Display for AttachmentError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Length(n) => write!(
                f,
                "attachment is {n} bytes, rmw_zenoh's is {ATTACHMENT_LEN}"
            ),
            Self::GidLength(n) => write!(f, "attachment GID length is {n}, expected 16"),
        }
    }
}

impl std::error::Error for AttachmentError {}

/// A 16-byte entity GID: XXH3-128 of the entity's liveliness token, low 64 bits
/// then high 64 bits, each little-endian (as rmw_zenoh_cpp computes it).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Gid(pub [u8; 16]);

impl Gid {
    /// The GID of the entity whose liveliness token is `token`.
    pub fn from_token(token: &str) -> Self {
        let hash = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
        let mut out = [0u8; 16];
        out[..8].copy_from_slice(&(hash as u64).to_le_bytes());
        out[8..].copy_from_slice(&((hash >> 64) as u64).to_le_bytes());
        Self(out)
    }
}

impl fmt::Debug for Gid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for b in self.0 {
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

/// Reliability QoS (rmw values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    /// `RMW_QOS_POLICY_RELIABILITY_RELIABLE` (1), rmw_zenoh's default.
    Reliable = 1,
    /// `RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT` (2).
    BestEffort = 2,
    /// `RMW_QOS_POLICY_RELIABILITY_BEST_AVAILABLE` (4), Jazzy and later:
    /// rclcpp's `BestAvailableQoS`, rclpy's `qos_profile_best_available`.
    /// rmw_zenoh_cpp announces it unresolved and, not being `Reliable`, puts
    /// best effort; so does a publisher here.
    BestAvailable = 4,
}

/// Durability QoS (rmw values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// `RMW_QOS_POLICY_DURABILITY_TRANSIENT_LOCAL` (1).
    TransientLocal = 1,
    /// `RMW_QOS_POLICY_DURABILITY_VOLATILE` (2), rmw_zenoh's default since
    /// ros2/rmw_zenoh#521 (every current release) and what ROS 2 nodes ask for.
    Volatile = 2,
    /// `RMW_QOS_POLICY_DURABILITY_BEST_AVAILABLE` (4), Jazzy and later:
    /// announced unresolved by rmw_zenoh_cpp, which keeps nothing for late
    /// subscribers of it (not `TransientLocal`), as a publisher here.
    BestAvailable = 4,
}

/// History QoS (rmw values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum History {
    /// `RMW_QOS_POLICY_HISTORY_KEEP_LAST` (1) with this depth.
    KeepLast(usize),
    /// `RMW_QOS_POLICY_HISTORY_KEEP_ALL` (2).
    KeepAll,
}

/// Liveliness QoS (rmw values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Liveliness {
    /// `RMW_QOS_POLICY_LIVELINESS_AUTOMATIC` (1): the default.
    Automatic = 1,
    /// `RMW_QOS_POLICY_LIVELINESS_MANUAL_BY_TOPIC` (3).
    ManualByTopic = 3,
    /// `RMW_QOS_POLICY_LIVELINESS_BEST_AVAILABLE` (5), Jazzy and later,
    /// announced unresolved by rmw_zenoh_cpp.
    BestAvailable = 5,
}

/// A QoS profile as it goes into a liveliness token and a Zenoh declaration.
/// Deadline, lifespan and liveliness are announced on the graph, as rmw_zenoh_cpp
/// announces them, so tools and peers see them; shm-runtime does not enforce
/// them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliability.
    pub reliability: Reliability,
    /// Durability.
    pub durability: Durability,
    /// History and depth.
    pub history: History,
    /// The longest expected gap between messages; `None` (the default): no
    /// deadline.
    pub deadline: Option<Duration>,
    /// How long a message stays valid; `None` (the default): for ever.
    /// rclcpp's `/rosout` says 10 s.
    pub lifespan: Option<Duration>,
    /// How the entity's liveliness is asserted.
    pub liveliness: Liveliness,
    /// The liveliness lease; `None` (the default): infinite.
    pub liveliness_lease: Option<Duration>,
}

impl Default for Qos {
    /// ROS 2's default profile: reliable, volatile, keep last 10.
    fn default() -> Self {
        Self::with_history(
            Reliability::Reliable,
            Durability::Volatile,
            History::KeepLast(10),
        )
    }
}

/// `RMW_DURATION_INFINITE`, rmw_zenoh's default for every duration: written as
/// empty fields in a token.
const INFINITE_SEC: u64 = 9_223_372_036;
const INFINITE_NSEC: u64 = 854_775_807;

/// A duration's `sec,nsec` token fields, each empty where it equals
/// `RMW_DURATION_INFINITE`'s (as rmw_zenoh_cpp writes them).
fn duration_fields(duration: Option<Duration>) -> String {
    let Some(duration) = duration else {
        return ",".to_owned();
    };
    let (sec, nsec) = (duration.as_secs(), u64::from(duration.subsec_nanos()));
    let sec = if sec == INFINITE_SEC {
        String::new()
    } else {
        sec.to_string()
    };
    let nsec = if nsec == INFINITE_NSEC {
        String::new()
    } else {
        nsec.to_string()
    };
    format!("{sec},{nsec}")
}

/// Read `sec,nsec` token fields back (empty: infinite's part); `None` for
/// infinite.
pub(crate) fn parse_duration_fields(sec: &str, nsec: &str) -> Option<Option<Duration>> {
    let sec: u64 = if sec.is_empty() {
        INFINITE_SEC
    } else {
        sec.parse().ok()?
    };
    let nsec: u64 = if nsec.is_empty() {
        INFINITE_NSEC
    } else {
        nsec.parse().ok()?
    };
    if (sec, nsec) == (INFINITE_SEC, INFINITE_NSEC) {
        return Some(None);
    }
    // rmw allows nsec past a second; Duration::new carries it over.
    let nsec = u32::try_from(nsec).ok()?;
    Some(Some(Duration::new(sec, nsec)))
}

impl Qos {
    /// A profile with these three policies and the defaults for the rest (no
    /// deadline, infinite lifespan, automatic liveliness).
    pub const fn with_history(
        reliability: Reliability,
        durability: Durability,
        history: History,
    ) -> Self {
        Self {
            reliability,
            durability,
            history,
            deadline: None,
            lifespan: None,
            liveliness: Liveliness::Automatic,
            liveliness_lease: None,
        }
    }

    /// This profile with a deadline.
    pub const fn deadline(mut self, deadline: Duration) -> Self {
        self.deadline = Some(deadline);
        self
    }

    /// This profile with a lifespan.
    pub const fn lifespan(mut self, lifespan: Duration) -> Self {
        self.lifespan = Some(lifespan);
        self
    }

    /// This profile with a liveliness kind and lease.
    pub const fn liveliness(mut self, liveliness: Liveliness, lease: Option<Duration>) -> Self {
        self.liveliness = liveliness;
        self.liveliness_lease = lease;
        self
    }

    /// `rmw_qos_profile_sensor_data`: best effort, volatile, keep last 5.
    pub const fn sensor_data() -> Self {
        Self::with_history(
            Reliability::BestEffort,
            Durability::Volatile,
            History::KeepLast(5),
        )
    }

    /// `rmw_qos_profile_services_default`: reliable, volatile, keep last 10 (what
    /// servers and clients announce, and how many requests a server keeps).
    pub const fn services_default() -> Self {
        Self::with_history(
            Reliability::Reliable,
            Durability::Volatile,
            History::KeepLast(10),
        )
    }

    /// `rmw_qos_profile_parameters`: reliable, volatile, keep last 1000.
    pub const fn parameters() -> Self {
        Self::with_history(
            Reliability::Reliable,
            Durability::Volatile,
            History::KeepLast(1000),
        )
    }

    /// `rmw_qos_profile_system_default` as rmw_zenoh_cpp resolves it: reliable,
    /// volatile, keep last 42 (every field of its token empty).
    pub const fn system_default() -> Self {
        Self::with_history(
            Reliability::Reliable,
            Durability::Volatile,
            History::KeepLast(42),
        )
    }

    /// `rclcpp::ClockQoS` (and rclpy's time source): `/clock`'s profile, best
    /// effort, volatile, keep last 1.
    pub const fn clock() -> Self {
        Self::with_history(
            Reliability::BestEffort,
            Durability::Volatile,
            History::KeepLast(1),
        )
    }

    /// A latched topic (`/tf_static`, `/map`): reliable, transient local, keep
    /// last `depth`; late subscribers receive the last `depth` messages.
    pub const fn transient_local(depth: usize) -> Self {
        Self::with_history(
            Reliability::Reliable,
            Durability::TransientLocal,
            History::KeepLast(depth),
        )
    }

    /// rmw_zenoh_cpp's `qos_to_keyexpr`: `rel:dur:hist,depth:dl_s,dl_ns:ls_s,ls_ns:liv,lease_s,lease_ns`,
    /// each field empty when it equals rmw_zenoh's default (reliable, volatile,
    /// keep-last 42, no deadline/lifespan, automatic liveliness), as in
    /// rmw_zenoh_cpp 0.6.7 (Kilted) `qos.cpp`. A peer re-writes our token in this
    /// canonical form and derives our GID from it, so it must match exactly.
    pub fn to_key_expr(&self) -> String {
        let reliability = match self.reliability {
            Reliability::Reliable => String::new(),
            other => (other as u8).to_string(),
        };
        let durability = match self.durability {
            Durability::Volatile => String::new(),
            other => (other as u8).to_string(),
        };
        let (history, depth) = match self.history {
            History::KeepLast(42) => (String::new(), String::new()),
            History::KeepLast(depth) => (String::new(), depth.to_string()),
            History::KeepAll => ("2".to_owned(), String::new()),
        };
        let liveliness = match self.liveliness {
            Liveliness::Automatic => String::new(),
            other => (other as u8).to_string(),
        };
        format!(
            "{reliability}:{durability}:{history},{depth}:{}:{}:{liveliness},{}",
            duration_fields(self.deadline),
            duration_fields(self.lifespan),
            duration_fields(self.liveliness_lease)
        )
    }
}

/// A name as it appears in a liveliness token: `/` becomes `%`, empty becomes `%`.
pub fn mangle_name(name: &str) -> String {
    if name.is_empty() {
        "%".to_owned()
    } else {
        name.replace('/', "%")
    }
}

/// The node part of liveliness tokens.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeInfo {
    /// ROS domain id.
    pub domain_id: u32,
    /// The Zenoh session id, as text.
    pub zid: String,
    /// The node's entity id within the session.
    pub node_id: u64,
    /// The security enclave (`/` if none).
    pub enclave: String,
    /// The namespace (`/` for the root).
    pub namespace: String,
    /// The node name.
    pub name: String,
    /// The distribution whose conventions the node's tokens and keys follow.
    pub distro: Distro,
}

impl NodeInfo {
    fn prefix(&self, entity_id: u64, kind: &str) -> String {
        format!(
            "@ros2_lv/{}/{}/{}/{entity_id}/{kind}/{}/{}/{}",
            self.domain_id,
            self.zid,
            self.node_id,
            mangle_name(&self.enclave),
            mangle_name(&self.namespace),
            mangle_name(&self.name)
        )
    }

    /// The node's fully qualified name (`/ns/name`).
    pub fn fqn(&self) -> String {
        if self.namespace.ends_with('/') {
            format!("{}{}", self.namespace, self.name)
        } else {
            format!("{}/{}", self.namespace, self.name)
        }
    }

    /// The node's own liveliness token (`NN`).
    pub fn node_token(&self) -> String {
        self.prefix(self.node_id, EntityKind::Node.as_str())
    }

    /// The liveliness token of a publisher (`MP`) or subscriber (`MS`) of message
    /// type `T` on `topic`.
    pub fn topic_token<T: RosMessage>(
        &self,
        entity_id: u64,
        kind: EntityKind,
        topic: &str,
        qos: &Qos,
    ) -> String {
        self.entity_token(
            entity_id,
            kind,
            topic,
            T::DDS_TYPE_NAME,
            T::type_hash(),
            qos,
        )
    }

    /// The liveliness token of a server (`SS`) or client (`SC`) of service type
    /// `S` on `service`.
    pub fn service_token<S: RosService>(
        &self,
        entity_id: u64,
        kind: EntityKind,
        service: &str,
        qos: &Qos,
    ) -> String {
        self.entity_token(
            entity_id,
            kind,
            service,
            S::DDS_TYPE_NAME,
            S::type_hash(),
            qos,
        )
    }

    /// The liveliness token of a publisher or subscriber of a type given at
    /// run time.
    pub(crate) fn topic_token_of(
        &self,
        entity_id: u64,
        kind: EntityKind,
        topic: &str,
        ty: &TopicType,
        qos: &Qos,
    ) -> String {
        self.entity_token(entity_id, kind, topic, &ty.dds_name(), &ty.hash, qos)
    }

    fn entity_token(
        &self,
        entity_id: u64,
        kind: EntityKind,
        name: &str,
        dds_type_name: &str,
        type_hash: &str,
        qos: &Qos,
    ) -> String {
        format!(
            "{}/{}/{dds_type_name}/{}/{}",
            self.prefix(entity_id, kind.as_str()),
            mangle_name(name),
            self.distro.hash_field(type_hash),
            qos.to_key_expr()
        )
    }
}

/// The key expression of the liveliness tokens of every `kind` endpoint with
/// the same domain, name, type and type hash as endpoint token `token`,
/// whoever declared them, whatever their QoS: e.g. the publishers (`MP`) a
/// subscriber's `MS` token can match, with or without the buffer backends
/// rmw_zenoh_cpp on Rolling appends after the QoS. `None` if `token` is not an
/// endpoint token.
pub fn counterpart_tokens_key_expr(token: &str, kind: EntityKind) -> Option<String> {
    // @ros2_lv/<domain>/<zid>/<nid>/<eid>/<kind>/<enclave>/<ns>/<node>/<name>/<type>/<hash>/<qos>
    let parts: Vec<&str> = token.split('/').collect();
    let [root, domain, _, _, _, _, _, _, _, name, type_name, hash, _] = parts.as_slice() else {
        return None;
    };
    Some(format!(
        "{root}/{domain}/*/*/*/{}/*/*/*/{name}/{type_name}/{hash}/**",
        kind.as_str()
    ))
}

/// The Zenoh session that declared a liveliness token of the ROS graph:
/// `@ros2_lv/<domain>/<zid>/…`.
pub(crate) fn token_session(token: &str) -> Option<zenoh::session::ZenohId> {
    let mut fields = token.split('/');
    match (fields.next(), fields.next(), fields.next()) {
        (Some("@ros2_lv"), Some(_domain), Some(zid)) => zid.parse().ok(),
        _ => None,
    }
}

/// A node's publisher or subscriber while it is being built: everything its
/// liveliness token says but the QoS. The token is written when the builder
/// resolves, from the QoS the builder holds then, so that it says what the
/// Zenoh declaration follows whichever way the QoS was given.
#[derive(Debug, Clone)]
pub(crate) struct TopicEndpoint {
    pub(crate) info: NodeInfo,
    pub(crate) entity_id: u64,
    pub(crate) kind: EntityKind,
    /// The resolved topic name.
    pub(crate) topic: String,
}

impl TopicEndpoint {
    /// The liveliness token, for `ty` with `qos`.
    pub(crate) fn token(&self, ty: &TopicType, qos: &Qos) -> String {
        self.info
            .topic_token_of(self.entity_id, self.kind, &self.topic, ty, qos)
    }
}

/// The kind of an entity in a liveliness token.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EntityKind {
    /// `NN`: a node.
    Node,
    /// `MP`: a publisher.
    Publisher,
    /// `MS`: a subscriber.
    Subscriber,
    /// `SS`: a service server.
    ServiceServer,
    /// `SC`: a service client.
    ServiceClient,
}

impl EntityKind {
    /// The two letters in the token.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Node => "NN",
            Self::Publisher => "MP",
            Self::Subscriber => "MS",
            Self::ServiceServer => "SS",
            Self::ServiceClient => "SC",
        }
    }

    /// The kind the two letters name.
    pub fn from_token_field(field: &str) -> Option<Self> {
        Some(match field {
            "NN" => Self::Node,
            "MP" => Self::Publisher,
            "MS" => Self::Subscriber,
            "SS" => Self::ServiceServer,
            "SC" => Self::ServiceClient,
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(shm_cdr::RosMessage)]
    #[ros(type_name = "std_msgs/msg/String")]
    struct StringMsg {
        data: String,
    }

    fn hex(bytes: &[u8]) -> String {
        bytes.iter().map(|b| format!("{b:02x}")).collect()
    }

    #[test]
    fn data_key_expression() {
        assert_eq!(
            topic_key_expr::<StringMsg>(Distro::Kilted, 0, "/chatter/"),
            "0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        // Humble's rmw_zenoh_cpp 0.1.9 has no type hashes.
        assert_eq!(
            topic_key_expr::<StringMsg>(Distro::Humble, 0, "/chatter/"),
            "0/chatter/std_msgs::msg::dds_::String_/TypeHashNotSupported"
        );
    }

    #[test]
    fn attachment_bytes() {
        let mut gid = [0u8; 16];
        for (i, b) in gid.iter_mut().enumerate() {
            *b = i as u8;
        }
        let a = Attachment {
            sequence_number: 1,
            source_timestamp: 1_700_000_000_123_456_789,
            gid: Gid(gid),
        };
        assert_eq!(
            hex(&a.to_bytes()),
            "010000000000000015cd853dfe9c971710000102030405060708090a0b0c0d0e0f"
        );
        assert_eq!(Attachment::parse(&a.to_bytes()).unwrap(), a);
        assert_eq!(
            Attachment::parse(&[0; 32]),
            Err(AttachmentError::Length(32))
        );
        let mut bad = a.to_bytes();
        bad[16] = 8;
        assert_eq!(Attachment::parse(&bad), Err(AttachmentError::GidLength(8)));
    }

    #[test]
    fn liveliness_token_and_gid() {
        let node = NodeInfo {
            domain_id: 2,
            zid: "8b20917502ee955ac4476e0266340d5c".into(),
            node_id: 0,
            enclave: "/".into(),
            namespace: "/".into(),
            name: "talker".into(),
            distro: Distro::Kilted,
        };
        let qos = Qos::transient_local(7);
        let token = node.topic_token::<StringMsg>(10, EntityKind::Publisher, "/chatter", &qos);
        assert_eq!(
            token,
            "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/:1:,7:,:,:,,"
        );
        assert_eq!(
            format!("{:?}", Gid::from_token(&token)),
            "b3e22299e7b519d0c200986fd38d822d" // Python xxhash 3: xxh3_128 of the token, low then high 64 bits LE
        );
        assert_eq!(
            node.node_token(),
            "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/0/NN/%/%/talker"
        );
    }

    #[test]
    fn counterparts_are_found_with_or_without_rolling_backends() {
        use zenoh::key_expr::KeyExpr;
        let subscriber = "@ros2_lv/0/ab/1/2/MS/%/%/n/%image/sensor_msgs::msg::dds_::Image_/RIHS01_00/::,10:,:,:,,";
        let Some(pattern) = counterpart_tokens_key_expr(subscriber, EntityKind::Publisher) else {
            panic!("an endpoint token has counterparts");
        };
        let pattern = KeyExpr::try_from(pattern).unwrap();
        let publisher = "@ros2_lv/0/cd/3/4/MP/%/%/m/%image/sensor_msgs::msg::dds_::Image_/RIHS01_00/:1:,1:,:,:,,";
        for token in [
            publisher.to_owned(),
            format!("{publisher}/backends:cpu:;cuda:device%3A0"),
        ] {
            assert!(
                pattern.intersects(&KeyExpr::try_from(token.as_str()).unwrap()),
                "{token}"
            );
        }
        let other_topic = publisher.replace("%image", "%depth");
        assert!(!pattern.intersects(&KeyExpr::try_from(other_topic.as_str()).unwrap()));
    }

    #[test]
    fn ros_default_qos_string() {
        // rmw_zenoh_cpp 0.6.7 writes ROS 2's default profile (reliable,
        // volatile, keep last 10) as `::,10:,:,:,,`.
        assert_eq!(Qos::default().to_key_expr(), "::,10:,:,:,,");
        let all = Qos::with_history(
            Reliability::BestEffort,
            Durability::TransientLocal,
            History::KeepAll,
        );
        assert_eq!(all.to_key_expr(), "2:1:2,:,:,:,,");
        // rclcpp's /rosout: a 10 s lifespan, as rmw_zenoh_cpp writes it.
        let rosout = Qos::transient_local(1000).lifespan(Duration::from_secs(10));
        assert_eq!(rosout.to_key_expr(), ":1:,1000:,:10,0:,,");
        let every = Qos::default()
            .deadline(Duration::from_millis(1500))
            .liveliness(Liveliness::ManualByTopic, Some(Duration::new(2, 5)));
        assert_eq!(every.to_key_expr(), "::,10:1,500000000:,:3,2,5");
    }
}
