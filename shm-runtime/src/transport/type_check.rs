//! Whether a sample is of the subscriber's type: our publishers on a plain key
//! name the type and its hash in each sample's encoding.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use zenoh::sample::Sample;

use crate::rmw::TopicType;

/// The check that a sample is of the subscriber's type: our publishers on a
/// plain key name the type and its RIHS01 hash in the sample's encoding
/// (`application/cdr;<type name>;<hash>`, see [`type_encoding`]). Samples
/// without that (a node's, whose key names the type; rmw_zenoh_cpp, plain
/// Zenoh, other tools) are taken as they are.
pub(crate) struct TypeCheck {
    /// `type_encoding(..)` of the type: the common case is one comparison.
    expected: zenoh::bytes::Encoding,
    ty: TopicType,
    key_expr: String,
    pub(crate) rejected: Arc<AtomicU64>,
}

impl TypeCheck {
    pub(crate) fn new(key_expr: &str, ty: &TopicType) -> Self {
        Self {
            expected: type_encoding(&ty.name, &ty.hash),
            ty: ty.clone(),
            key_expr: key_expr.to_owned(),
            rejected: Arc::new(AtomicU64::new(0)),
        }
    }

    /// Whether `sample` may be of this type; if it names another, count it and
    /// say (once) which type arrived.
    pub(crate) fn accepts(&self, sample: &Sample) -> bool {
        let encoding = sample.encoding();
        // Only a schema can name a type: rmw_zenoh_cpp's samples and a node's
        // (whose key names the type) carry none.
        if encoding.schema().is_none() || *encoding == self.expected {
            return true;
        }
        let Some((name, hash)) = sample_type(sample) else {
            return true;
        };
        if *name == *self.ty.name && *hash == *self.ty.hash {
            return true;
        }
        if self.rejected.fetch_add(1, Ordering::Relaxed) == 0 {
            tracing::warn!(
                key_expr = %self.key_expr,
                expected = %format!("{} {}", self.ty.name, self.ty.hash),
                received = %format!("{name} {hash}"),
                "samples of another message type on this key are dropped (RosSubscriber::wrong_type() counts them)"
            );
        }
        false
    }
}

/// The message type (name, RIHS01 hash) a sample's encoding names, if it names
/// one: `application/cdr;<name>;<hash>`.
pub(crate) fn sample_type(sample: &Sample) -> Option<(String, String)> {
    let encoding = sample.encoding().to_string();
    let (name, hash) = encoding.strip_prefix("application/cdr;")?.split_once(';')?;
    Some((name.to_owned(), hash.to_owned()))
}

/// The encoding our publishers on a plain key give every sample of a type:
/// `application/cdr;<type name>;<RIHS01 hash>`, or plain `application/cdr`
/// for a type whose name is too long for that: Zenoh writes an encoding's
/// schema with a one-byte length, and panics on anything longer than 255
/// bytes (a type name of more than 183 characters with its hash).
pub(crate) fn type_encoding(name: &str, hash: &str) -> zenoh::bytes::Encoding {
    const ZENOH_SCHEMA_MAX: usize = 255;
    let schema = format!("{name};{hash}");
    if schema.len() > ZENOH_SCHEMA_MAX {
        return zenoh::bytes::Encoding::APPLICATION_CDR;
    }
    zenoh::bytes::Encoding::APPLICATION_CDR.with_schema(schema)
}
