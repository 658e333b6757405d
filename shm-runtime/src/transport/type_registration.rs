//! What a node keeps while an endpoint of the transport uses a type: the
//! transport holds it for as long as the endpoint lives and hands it the
//! interface files' text the endpoint is given, without knowing what a node
//! does with either.

use std::sync::Arc;

/// A node's registration of the type (and topic) an endpoint uses: kept
/// alive by the endpoint, released when it drops.
pub(crate) trait TypeRegistration: Send + Sync {
    /// The interface files' own text (`(pkg/msg/Name, text)`) for a type known
    /// at run time, in place of the text written back from its description.
    fn offer_sources(&self, sources: &[(String, String)]);
}

/// A registration shared by a builder and the endpoint it builds.
pub(crate) type Registered = Arc<dyn TypeRegistration>;

/// `(name, text)` pairs as the builders' `type_sources` take them, owned.
pub(crate) fn owned_sources<N: Into<String>, S: Into<String>>(
    sources: impl IntoIterator<Item = (N, S)>,
) -> Vec<(String, String)> {
    sources
        .into_iter()
        .map(|(name, text)| (name.into(), text.into()))
        .collect()
}
