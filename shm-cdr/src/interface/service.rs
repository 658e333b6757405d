//! [`RosService`]: a service type's request, response and event messages.

use crate::describe::{
    Field, FieldType, FullDescription, TypeDescription, TypeRegistry, TypeSource,
};
use crate::{DecodeOwned, RosMessage, RosType};

/// A ROS 2 service type, e.g. `std_srvs/srv/Trigger`: the messages a call
/// exchanges, and the type hash rmw_zenoh_cpp puts in the service's key.
///
/// Implementations are generated from `.srv` files (shm-codegen); a hand-written
/// one must name rosidl's types: `pkg/srv/Name_Request`, `…_Response` and
/// `…_Event`.
pub trait RosService: 'static {
    /// `pkg/srv/Name`.
    const TYPE_NAME: &'static str;

    /// `pkg::srv::dds_::Name_`, as rmw_zenoh_cpp writes it in key expressions.
    const DDS_TYPE_NAME: &'static str;

    /// The request message.
    type Request: RosMessage + DecodeOwned + Send + Sync;

    /// The response message.
    type Response: RosMessage + DecodeOwned + Send + Sync;

    /// The introspection event message (`service_msgs/ServiceEventInfo info`, the
    /// request and the response as sequences of at most one).
    type Event: RosMessage + DecodeOwned;

    /// The `.srv` file the type was generated from
    /// ([`TypeSource::NONE`] for a hand-written implementation).
    const SOURCE: TypeSource = TypeSource::NONE;

    /// The type's own description, as rosidl hashes it.
    const FIELDS: &'static [Field] = &[
        Field::new(
            "request_message",
            FieldType::nested(<Self::Request as RosMessage>::TYPE_NAME),
        ),
        Field::new(
            "response_message",
            FieldType::nested(<Self::Response as RosMessage>::TYPE_NAME),
        ),
        Field::new(
            "event_message",
            FieldType::nested(<Self::Event as RosMessage>::TYPE_NAME),
        ),
    ];

    /// The REP 2011 hash of the service, covering request, response and event,
    /// equal to rosidl's (generated code caches it).
    fn type_hash() -> &'static str;

    /// Register this service's description and every type it references.
    /// The type's own description (referenced types excluded).
    fn type_description() -> TypeDescription {
        TypeDescription::new(Self::TYPE_NAME, Self::FIELDS, Self::SOURCE)
    }

    /// The service's description with every type it references, as its
    /// type-description service reply carries it.
    fn full_description() -> FullDescription
    where
        Self: Sized,
    {
        FullDescription::collect(Self::type_description(), Self::register_types)
    }

    /// Register this service's description and every type it references.
    fn register_types(registry: &mut TypeRegistry) {
        let own = Self::type_description();
        if registry.insert(own) {
            <Self::Request as RosType>::register_types(registry);
            <Self::Response as RosType>::register_types(registry);
            <Self::Event as RosType>::register_types(registry);
        }
    }
}

/// Compute the RIHS01 hash of service `S` (what generated `type_hash` caches).
pub fn compute_service_hash<S: RosService>() -> String {
    FullDescription::collect(S::type_description(), S::register_types).type_hash()
}
