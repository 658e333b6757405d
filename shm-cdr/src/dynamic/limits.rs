//! Bounds on a run-time type: a description can come from any node on the
//! network, and the hash it is announced with is the sender's own, so what a
//! type may cost is checked before anything is built from it.

/// Limits a [`DynamicType`](super::DynamicType) is built within. A
/// description past any of them is refused with a
/// [`TypeError`](super::TypeError) naming the limit, the type and the field.
///
/// The defaults hold every type of ROS 2's interface packages many times
/// over (the deepest nest five levels) and keep what a type can cost small:
/// built, a type takes memory linear in its description, every walk over it
/// or its messages recurses at most [`max_depth`](Self::max_depth) levels,
/// and its default message takes at most
/// [`max_default_size`](Self::max_default_size) bytes.
///
/// ```
/// use shm_cdr::dynamic::{DynamicType, TypeLimits};
/// use shm_cdr::msgs::nav_msgs::Odometry;
/// use shm_cdr::RosMessage;
///
/// let mut limits = TypeLimits::default();
/// limits.max_depth = 3;
/// let refused = DynamicType::from_description_with(&Odometry::full_description(), &limits)
///     .unwrap_err();
/// assert!(refused.reason.contains("max_depth"), "{refused}");
/// assert!(DynamicType::from_description(&Odometry::full_description()).is_ok());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct TypeLimits {
    /// How many levels messages may nest, the type itself being level 1.
    pub max_depth: usize,
    /// How many types a description may hold, the type itself included.
    pub max_types: usize,
    /// How many fields all the types together may have.
    pub max_fields: usize,
    /// How many fields one message may hold, counting those of the messages
    /// it nests by value (not those in arrays or sequences, whose number the
    /// payload gives and its length bounds).
    pub max_message_fields: usize,
    /// The longest type or field name, in bytes (`type_description_interfaces`
    /// bounds type names to 255).
    pub max_name_len: usize,
    /// The longest default value text, in bytes.
    pub max_default_len: usize,
    /// The most memory, in bytes, a message of the type may take at its
    /// smallest: its default, with every element of its fixed arrays. A
    /// message of a larger type could never be made, nor carried whole.
    pub max_default_size: usize,
}

impl TypeLimits {
    /// The defaults.
    pub const DEFAULT: Self = Self {
        max_depth: 32,
        max_types: 1024,
        max_fields: 1 << 16,
        max_message_fields: 1 << 16,
        max_name_len: 255,
        max_default_len: 1 << 16,
        max_default_size: 64 << 20,
    };

    /// No limits: for a type already built within some (one of its members,
    /// say).
    pub(crate) const UNLIMITED: Self = Self {
        max_depth: usize::MAX,
        max_types: usize::MAX,
        max_fields: usize::MAX,
        max_message_fields: usize::MAX,
        max_name_len: usize::MAX,
        max_default_len: usize::MAX,
        max_default_size: usize::MAX,
    };
}

impl Default for TypeLimits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The most fields a message may hold per byte of its smallest encoding (a
/// message nested `max_depth` deep holds one field per level): what bounds
/// the table a [view](super::MessageView) keeps by the payload's length.
pub(crate) const MAX_FIELDS_PER_BYTE: usize = 64;

/// The bytes one decoded value takes beside what it holds (the size of a
/// [`Value`](super::Value)), and one message beside its values (of a
/// [`Message`](super::Message)): what a type's default message is counted in
/// against [`TypeLimits::max_default_size`]. `value.rs` checks both at
/// compile time.
pub(crate) const VALUE_BYTES: usize = 32;
/// See [`VALUE_BYTES`].
pub(crate) const MESSAGE_BYTES: usize = 72;
