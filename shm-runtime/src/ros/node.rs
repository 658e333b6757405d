//! [`RosNode`]: rmw_zenoh_cpp-compatible topics on the caller's session, with a
//! shared shared-memory default for the node's publishers.

use std::future::IntoFuture;
use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use shm_cdr::dynamic::DynamicType;
use shm_cdr::interface::{RosAction, RosService};
use shm_cdr::msgs::rcl_interfaces::srv::{GetLoggerLevels, SetLoggerLevels};
use shm_cdr::msgs::type_description_interfaces::srv::GetTypeDescription;
use shm_cdr::RosMessage;
use zenoh::liveliness::LivelinessToken;
use zenoh::{Resolvable, Session, Wait};

use crate::rmw::TopicType;
use crate::rmw::{
    service_key_expr, topic_key_expr_of, Distro, EntityKind, Gid, NodeInfo, Qos, TopicEndpoint,
    UnknownDistro,
};
use crate::ros::action::{ActionClientBuilder, ActionServerBuilder};
use crate::ros::graph::{Graph, GraphCache};
use crate::ros::log_levels::{self, LogLevel};
use crate::ros::names::{self, NameError, NameKind, RemapRule, Remaps};
use crate::ros::parameters::{
    OverrideError, ParameterClient, ParameterDescriptor, ParameterError, ParameterOverrides,
    ParameterServer, ParameterValue, SetResult,
};
use crate::ros::service::{ServiceClientBuilder, ServiceServerBuilder};
use crate::ros::time::{Clock, RosTime, Timer};
use crate::ros::topic_types::{TopicTypes, TypeConflict};
use crate::ros::type_description::{TypeCache, TypeUse};
use crate::transport::limits::check_key_expr;
use crate::transport::pool::ShmContext;
use crate::transport::publisher::PublisherBuilder;
use crate::transport::subscriber::SubscriberBuilder;

/// The parameter every ROS node has, switching its clock to `/clock`.
const USE_SIM_TIME: &str = "use_sim_time";

/// The parameter rclcpp and rclpy read at startup to leave
/// `~/get_type_description` out.
const START_TYPE_DESCRIPTION_SERVICE: &str = "start_type_description_service";

/// Entity ids are unique per process, hence per session as rmw_zenoh requires.
static NEXT_ENTITY_ID: AtomicU64 = AtomicU64::new(0);

/// A ROS 2 node on a Zenoh session, visible to rmw_zenoh_cpp's graph through its
/// liveliness token. Undeclared when dropped.
pub struct RosNode {
    session: Session,
    info: NodeInfo,
    shm: Option<ShmContext>,
    remaps: Remaps,
    graph: std::sync::Mutex<Option<GraphCache>>,
    clock: Clock,
    parameters: std::sync::Mutex<Option<Arc<ParameterServer>>>,
    /// The types the node's entities use, for `~/get_type_description`.
    types: Arc<TypeCache>,
    /// The node's topics and their types, against the graph's.
    topic_types: TopicTypes,
    type_description_service: Option<Box<dyn std::any::Any + Send + Sync>>,
    logger_services: Option<Box<dyn std::any::Any + Send + Sync>>,
    /// Initial parameter values from the command line, for this node.
    overrides: Vec<(String, ParameterValue)>,
    _token: LivelinessToken,
}

impl std::fmt::Debug for RosNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RosNode")
            .field("info", &self.info)
            .field("shm", &self.shm)
            .finish()
    }
}

impl RosNode {
    /// Start declaring a node called `name` on `session`.
    pub fn builder<'a>(session: &'a Session, name: &str) -> RosNodeBuilder<'a> {
        RosNodeBuilder {
            session,
            name: name.to_owned(),
            namespace: "/".to_owned(),
            enclave: "/".to_owned(),
            domain_id: names::domain_id_from(std::env::var("ROS_DOMAIN_ID").ok().as_deref()),
            distro: Distro::from_env(),
            shm: None,
            remaps: Remaps::default(),
            use_sim_time: false,
            type_description_service: true,
            parameter_services: true,
            logger_service: false,
            log_levels: Vec::new(),
            overrides: ParameterOverrides::default(),
            invalid: None,
            invalid_override: None,
            invalid_log_level: None,
            router_check: true,
        }
    }

    /// The node's identity in liveliness tokens.
    pub fn info(&self) -> &NodeInfo {
        &self.info
    }

    /// The shared-memory default of the node's publishers.
    pub fn shm(&self) -> Option<&ShmContext> {
        self.shm.as_ref()
    }

    /// A publisher of `T` on ROS topic `topic` (e.g. `"/chatter"`), with
    /// rmw_zenoh's key expression, liveliness token, GID and attachment. It uses the
    /// node's shared memory unless overridden on the builder.
    pub fn declare_publisher<T: RosMessage>(&self, topic: &str) -> PublisherBuilder<'_, T> {
        self.declare_publisher_with_qos(topic, Qos::default())
    }

    /// [`declare_publisher`](Self::declare_publisher) with an explicit QoS, in the
    /// liveliness token and in the Zenoh declaration (see
    /// [`PublisherBuilder::qos`]): e.g. [`Qos::transient_local`] for a latched
    /// topic.
    pub fn declare_publisher_with_qos<T: RosMessage>(
        &self,
        topic: &str,
        qos: Qos,
    ) -> PublisherBuilder<'_, T> {
        let type_use = self.topic_type_use::<T>(topic);
        self.node_publisher(topic, qos, TopicType::of::<T>(), Some(type_use))
    }

    /// A publisher of messages typed at run time: `ty`'s messages on `topic`,
    /// announced and keyed exactly as a publisher of the compiled type would be,
    /// so ROS 2 subscribers of that type receive them. Publish with
    /// [`RosPublisher::publish_dynamic`](crate::RosPublisher::publish_dynamic).
    /// The node's `~/get_type_description` describes `ty` while the publisher
    /// lives, with `.msg` text written back from it, or the files' own text
    /// given to [`PublisherBuilder::type_sources`](crate::PublisherBuilder::type_sources).
    ///
    /// ```no_run
    /// use shm_cdr::dynamic::{DynamicType, Value};
    /// use shm_cdr::msgs::std_msgs::String as RosString;
    /// use shm_cdr::RosMessage;
    /// use shm_runtime::rmw::Qos;
    /// use shm_runtime::RosNode;
    /// use zenoh::Wait;
    ///
    /// let session = zenoh::open(zenoh::Config::default()).wait()?;
    /// let node = RosNode::builder(&session, "talker").wait()?;
    /// // A type known only at run time (here from a compiled type's description).
    /// let ty = DynamicType::from_description(&RosString::full_description())?;
    /// let publisher = node.declare_dynamic_publisher("/chatter", &ty, Qos::default()).wait()?;
    /// let mut message = ty.default_message();
    /// message.set("data", Value::String("hello".into()))?;
    /// publisher.publish_dynamic(&message).wait()?;
    /// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    /// ```
    pub fn declare_dynamic_publisher(
        &self,
        topic: &str,
        ty: &DynamicType,
        qos: Qos,
    ) -> PublisherBuilder<'_, DynamicType> {
        let type_use = self.types.register_dynamic(ty);
        let mut builder =
            self.node_publisher(topic, qos, TopicType::of_dynamic(ty), Some(type_use));
        builder.dynamic = Some(ty.clone());
        builder
    }

    /// A publisher of messages given already serialized (their CDR bytes, as a
    /// recording keeps them) of the type `type_name` (`pkg/msg/Name`) with
    /// RIHS01 hash `type_hash`: announced and keyed exactly as a publisher of
    /// that type, for a program that moves messages without their type, such
    /// as a player of recordings. Publish with
    /// [`RosPublisher::publish_serialized`](crate::RosPublisher::publish_serialized).
    ///
    /// ```no_run
    /// use shm_cdr::msgs::std_msgs::String as RosString;
    /// use shm_cdr::RosMessage;
    /// use shm_runtime::rmw::Qos;
    /// use shm_runtime::RosNode;
    /// use zenoh::Wait;
    ///
    /// let session = zenoh::open(zenoh::Config::default()).wait()?;
    /// let node = RosNode::builder(&session, "player").wait()?;
    /// let publisher = node
    ///     .declare_serialized_publisher("/chatter", RosString::TYPE_NAME, RosString::type_hash(), Qos::default())
    ///     .wait()?;
    /// // "hi" as rclpy serializes a std_msgs/msg/String.
    /// publisher.publish_serialized(&[0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0])?;
    /// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    /// ```
    pub fn declare_serialized_publisher(
        &self,
        topic: &str,
        type_name: &str,
        type_hash: &str,
        qos: Qos,
    ) -> PublisherBuilder<'_, crate::Serialized> {
        let topic_type = TopicType {
            name: type_name.into(),
            hash: type_hash.into(),
            // Our publishers publish on the base key whatever the type.
            has_buffer_fields: false,
        };
        self.node_publisher(topic, qos, topic_type, None)
    }

    fn node_publisher<T>(
        &self,
        topic: &str,
        qos: Qos,
        topic_type: TopicType,
        type_use: Option<TypeUse>,
    ) -> PublisherBuilder<'_, T> {
        let entity_id = NEXT_ENTITY_ID.fetch_add(1, Ordering::Relaxed) + 1;
        let (topic, invalid) = self.resolve(topic, NameKind::Topic);
        let key_expr =
            topic_key_expr_of(self.info.distro, self.info.domain_id, &topic, &topic_type);
        let mut builder = PublisherBuilder::new(&self.session, key_expr, topic_type);
        builder.invalid = invalid.map(Into::into);
        builder.qos = qos;
        builder.shm.inherited = self.shm.clone();
        builder.node = Some(TopicEndpoint {
            info: self.info.clone(),
            entity_id,
            kind: EntityKind::Publisher,
            topic,
        });
        builder.type_use = type_use.map(TypeUse::registered);
        builder
    }

    /// A subscriber to `T` on ROS topic `topic`, announced to the ROS graph by
    /// its `MS` liveliness token.
    pub fn declare_subscriber<T: RosMessage>(&self, topic: &str) -> SubscriberBuilder<'_, T> {
        self.declare_subscriber_with_qos(topic, Qos::default())
    }

    /// [`declare_subscriber`](Self::declare_subscriber) with an explicit QoS, in
    /// the liveliness token and in the Zenoh declaration (see
    /// [`SubscriberBuilder::qos`]): [`Qos::transient_local`] receives the last
    /// messages of latched topics.
    pub fn declare_subscriber_with_qos<T: RosMessage>(
        &self,
        topic: &str,
        qos: Qos,
    ) -> SubscriberBuilder<'_, T> {
        let type_use = self.topic_type_use::<T>(topic);
        node_subscriber(
            &self.session,
            &self.info,
            &self.remaps,
            topic,
            qos,
            TopicType::of::<T>(),
            Some(type_use),
        )
    }

    /// A subscriber to messages typed at run time: `ty`'s messages on
    /// `topic`, announced and keyed as a subscriber of the compiled type would
    /// be. Read the samples with [`DynamicType::decode`] (borrowing from the
    /// sample, as the generated `…Ref` types do).
    ///
    /// ```no_run
    /// use shm_cdr::dynamic::DynamicType;
    /// use shm_cdr::msgs::std_msgs::String as RosString;
    /// use shm_cdr::RosMessage;
    /// use shm_runtime::rmw::Qos;
    /// use shm_runtime::RosNode;
    /// use zenoh::Wait;
    ///
    /// let session = zenoh::open(zenoh::Config::default()).wait()?;
    /// let node = RosNode::builder(&session, "listener").wait()?;
    /// let ty = DynamicType::from_description(&RosString::full_description())?;
    /// let subscriber = node.declare_dynamic_subscriber("/chatter", &ty, Qos::default()).wait()?;
    /// while let Ok(sample) = subscriber.recv() {
    ///     let bytes = sample.payload().to_bytes();
    ///     print!("{}---\n", ty.decode(&bytes)?.to_yaml());
    /// }
    /// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    /// ```
    pub fn declare_dynamic_subscriber(
        &self,
        topic: &str,
        ty: &DynamicType,
        qos: Qos,
    ) -> SubscriberBuilder<'_, DynamicType> {
        node_subscriber(
            &self.session,
            &self.info,
            &self.remaps,
            topic,
            qos,
            TopicType::of_dynamic(ty),
            Some(self.types.register_dynamic(ty)),
        )
    }

    /// A subscriber to messages of the type `type_name` (`pkg/msg/Name`) with
    /// RIHS01 hash `type_hash`, taken as bytes without knowing the type's
    /// fields: announced and keyed exactly as a subscriber of that type, for a
    /// program that moves messages it need not read, such as a recorder that
    /// subscribes at once and learns the type's definition meanwhile.
    ///
    /// Not knowing whether the type has a `uint8[]` field of its own, it also
    /// listens where a buffer-aware publisher of Lyrical and later sends such
    /// types (see [`crate::rmw::buffer_key_expr`]); a publisher of any other
    /// type never sends there.
    ///
    /// ```no_run
    /// use shm_runtime::rmw::Qos;
    /// use shm_runtime::RosNode;
    /// use zenoh::Wait;
    ///
    /// let session = zenoh::open(zenoh::Config::default()).wait()?;
    /// let node = RosNode::builder(&session, "relay").wait()?;
    /// let subscriber = node
    ///     .declare_serialized_subscriber("/scan", "my_robot/msg/Scan", "RIHS01_…", Qos::default())
    ///     .wait()?;
    /// while let Ok(sample) = subscriber.recv() {
    ///     println!("{} bytes", sample.payload().len());
    /// }
    /// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    /// ```
    pub fn declare_serialized_subscriber(
        &self,
        topic: &str,
        type_name: &str,
        type_hash: &str,
        qos: Qos,
    ) -> SubscriberBuilder<'_, crate::Serialized> {
        let topic_type = TopicType {
            name: type_name.into(),
            hash: type_hash.into(),
            has_buffer_fields: true,
        };
        node_subscriber(
            &self.session,
            &self.info,
            &self.remaps,
            topic,
            qos,
            topic_type,
            None,
        )
    }

    /// A server of service `S` on `service` (e.g. `"/trigger"`, resolved like a
    /// topic name): a queryable on rmw_zenoh's service key with an `SS`
    /// liveliness token. Resolve it as it is for a queue of
    /// [`ServiceRequest`](crate::ros::service::ServiceRequest)s, or give it a
    /// [`handler`](crate::ros::service::ServiceServerBuilder::handler) or
    /// [`callback`](crate::ros::service::ServiceServerBuilder::callback) first. It
    /// keeps `Qos::services_default()`'s 10 requests waiting unless told
    /// otherwise, and replies from the node's shared memory.
    pub fn declare_service<S: RosService>(&self, service: &str) -> ServiceServerBuilder<'_, S> {
        let entity_id = NEXT_ENTITY_ID.fetch_add(1, Ordering::Relaxed) + 1;
        let (service, invalid) = self.resolve(service, NameKind::Service);
        let qos = Qos::services_default();
        let token =
            self.info
                .service_token::<S>(entity_id, EntityKind::ServiceServer, &service, &qos);
        let mut builder = ServiceServerBuilder::new(
            &self.session,
            service_key_expr::<S>(self.info.distro, self.info.domain_id, &service),
        );
        builder.gid = Some(Gid::from_token(&token));
        builder.token = Some(token);
        builder.type_use = Some(self.types.register(S::type_hash(), S::full_description));
        builder.invalid = invalid;
        builder.shm.inherited = self.shm.clone();
        builder.history = server_history(&qos);
        builder
    }

    /// A server of the service type `type_name` (`pkg/srv/Name`) with RIHS01
    /// hash `type_hash`, for requests taken and responses given serialized:
    /// announced and keyed exactly as a server of that type, for a program
    /// that serves types it learns at run time. Take its requests with
    /// [`ServiceRequest::serialized`](crate::service::ServiceRequest::serialized)
    /// and answer with
    /// [`ServiceRequest::reply_serialized`](crate::service::ServiceRequest::reply_serialized).
    /// Replies carry plain `application/cdr`, as the requests of
    /// [`declare_serialized_client`](Self::declare_serialized_client) do.
    /// The node does not describe the type to others; a server of a
    /// [`DynamicType`] does ([`declare_dynamic_service`](Self::declare_dynamic_service)).
    pub fn declare_serialized_service(
        &self,
        service: &str,
        type_name: &str,
        type_hash: &str,
    ) -> ServiceServerBuilder<'_, crate::Serialized> {
        self.serialized_service(service, type_name, type_hash, None)
    }

    /// [`declare_serialized_service`](Self::declare_serialized_service) of
    /// the service type `ty` (a service as one run-time type, as
    /// `types::service_type_by_name` gives one), which the node describes to others through its type-description
    /// service, as it describes the types of its other endpoints.
    pub fn declare_dynamic_service(
        &self,
        service: &str,
        ty: &DynamicType,
    ) -> ServiceServerBuilder<'_, crate::Serialized> {
        let type_use = self.types.register_dynamic(ty);
        self.serialized_service(service, ty.name(), &ty.type_hash(), Some(type_use))
    }

    fn serialized_service(
        &self,
        service: &str,
        type_name: &str,
        type_hash: &str,
        type_use: Option<TypeUse>,
    ) -> ServiceServerBuilder<'_, crate::Serialized> {
        let qos = Qos::services_default();
        let (key_expr, token, invalid) =
            self.named_service_endpoint(service, type_name, type_hash, EntityKind::ServiceServer);
        let mut builder = ServiceServerBuilder::with_response_encoding(
            &self.session,
            key_expr,
            zenoh::bytes::Encoding::APPLICATION_CDR,
        );
        builder.gid = Some(Gid::from_token(&token));
        builder.token = Some(token);
        builder.type_use = type_use;
        builder.invalid = invalid;
        builder.shm.inherited = self.shm.clone();
        builder.history = server_history(&qos);
        builder
    }

    /// The key expression and liveliness token of a service server or
    /// client (`kind`) on `service` of the type named `type_name` with hash
    /// `type_hash`, with services' default QoS; and the name's error, if it
    /// did not resolve.
    fn named_service_endpoint(
        &self,
        service: &str,
        type_name: &str,
        type_hash: &str,
        kind: EntityKind,
    ) -> (String, String, Option<NameError>) {
        let entity_id = NEXT_ENTITY_ID.fetch_add(1, Ordering::Relaxed) + 1;
        let (service, invalid) = self.resolve(service, NameKind::Service);
        let service_type = TopicType {
            name: type_name.into(),
            hash: type_hash.into(),
            has_buffer_fields: false,
        };
        let token = self.info.topic_token_of(
            entity_id,
            kind,
            &service,
            &service_type,
            &Qos::services_default(),
        );
        let key_expr = topic_key_expr_of(
            self.info.distro,
            self.info.domain_id,
            &service,
            &service_type,
        );
        (key_expr, token, invalid)
    }

    /// A client of service `S` on `service`, with an `SC` liveliness token; its
    /// requests go out from the node's shared memory at or above the threshold.
    pub fn declare_client<S: RosService>(&self, service: &str) -> ServiceClientBuilder<'_, S> {
        let entity_id = NEXT_ENTITY_ID.fetch_add(1, Ordering::Relaxed) + 1;
        let (service, invalid) = self.resolve(service, NameKind::Service);
        let token = self.info.service_token::<S>(
            entity_id,
            EntityKind::ServiceClient,
            &service,
            &Qos::services_default(),
        );
        let mut builder = ServiceClientBuilder::new(
            &self.session,
            service_key_expr::<S>(self.info.distro, self.info.domain_id, &service),
            token,
        );
        builder.type_use = Some(self.types.register(S::type_hash(), S::full_description));
        builder.invalid = invalid;
        builder.shm.inherited = self.shm.clone();
        builder
    }

    /// A client of the service type `type_name` (`pkg/srv/Name`) with RIHS01
    /// hash `type_hash`, for requests given already serialized: announced and
    /// keyed exactly as a client of that type, for a program that calls
    /// services whose type it learns at run time (a command line). Call it
    /// with [`ServiceClient::call_serialized`](crate::service::ServiceClient::call_serialized).
    pub fn declare_serialized_client(
        &self,
        service: &str,
        type_name: &str,
        type_hash: &str,
    ) -> ServiceClientBuilder<'_, crate::Serialized> {
        let (key_expr, token, invalid) =
            self.named_service_endpoint(service, type_name, type_hash, EntityKind::ServiceClient);
        // The request's own type is not known here: requests carry plain CDR.
        let mut builder = ServiceClientBuilder::with_request_encoding(
            &self.session,
            key_expr,
            token,
            zenoh::bytes::Encoding::APPLICATION_CDR,
        );
        builder.invalid = invalid;
        builder.shm.inherited = self.shm.clone();
        builder
    }

    /// A server of action `A` on `action` (e.g. `"/fibonacci"`, resolved like a
    /// topic name): its three services and two topics under
    /// `<action>/_action/`, as rcl_action and rmw_zenoh_cpp name them. Resolve
    /// it as it is (every goal accepted, every cancel accepted) or decide with
    /// [`on_goal`](crate::ros::action::ActionServerBuilder::on_goal) /
    /// [`on_cancel`](crate::ros::action::ActionServerBuilder::on_cancel) first.
    pub fn declare_action_server<A: RosAction>(&self, action: &str) -> ActionServerBuilder<'_, A> {
        ActionServerBuilder::new(self, action)
    }

    /// A client of action `A` on `action`.
    pub fn declare_action_client<A: RosAction>(&self, action: &str) -> ActionClientBuilder<'_, A> {
        ActionClientBuilder::new(self, action)
    }

    /// The node's parameters, their six services and `/parameter_events`,
    /// started with the node or on first use.
    fn parameter_server(&self) -> Result<Arc<ParameterServer>, ParameterError> {
        let mut server = self.parameters.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(server) = server.as_ref() {
            return Ok(server.clone());
        }
        let started = Arc::new(
            ParameterServer::start(self).map_err(|e| ParameterError::Zenoh(e.to_string()))?,
        );
        // `use_sim_time`, as every rclcpp and rclpy node has it: setting it
        // switches the node's clock.
        let switch = self.sim_time_switch();
        started.add_after_set(Box::new(move |set| {
            for (name, value) in set {
                if let (USE_SIM_TIME, ParameterValue::Bool(on)) = (name.as_str(), value) {
                    if let Err(e) = switch.set(*on) {
                        tracing::warn!("use_sim_time: {e}");
                    }
                }
            }
        }));
        let use_sim_time = self
            .overrides
            .iter()
            .find(|(name, _)| name == USE_SIM_TIME)
            .map_or(ParameterValue::Bool(self.clock.is_simulated()), |(_, v)| {
                v.clone()
            });
        started.declare(USE_SIM_TIME, use_sim_time, ParameterDescriptor::default())?;
        *server = Some(started.clone());
        Ok(started)
    }

    /// Declare parameter `name` with the value `default` (statically typed:
    /// it keeps that type); returns its value. The first declaration starts
    /// the node's parameter services (`~/list_parameters`, `~/get_parameters`,
    /// `~/get_parameter_types`, `~/describe_parameters`, `~/set_parameters`,
    /// `~/set_parameters_atomically`), which answer as rclpy's do, and
    /// `/parameter_events`, where every declaration and change is announced.
    pub fn declare_parameter(
        &self,
        name: &str,
        default: impl Into<ParameterValue>,
    ) -> Result<ParameterValue, ParameterError> {
        self.declare_parameter_with(name, default, ParameterDescriptor::default())
    }

    /// [`declare_parameter`](Self::declare_parameter) with a descriptor:
    /// description, read-only, dynamic typing, ranges. A value given on the
    /// command line (`-p`, `--params-file`; see
    /// [`RosNodeBuilder::ros_args`]) replaces the default; it must be of the
    /// default's type unless the parameter is dynamically typed. A value
    /// outside the range is an error saying why.
    pub fn declare_parameter_with(
        &self,
        name: &str,
        default: impl Into<ParameterValue>,
        descriptor: ParameterDescriptor,
    ) -> Result<ParameterValue, ParameterError> {
        let default = default.into();
        let value = match self.overrides.iter().find(|(n, _)| n == name) {
            Some((_, given)) => {
                if !descriptor.dynamic_typing
                    && !matches!(default, ParameterValue::NotSet)
                    && given.type_code() != default.type_code()
                {
                    return Err(ParameterError::InvalidValue {
                        name: name.to_owned(),
                        reason: format!(
                            "the value given on the command line ({given}) is of type {}, the parameter's default of type {}",
                            given.type_code(),
                            default.type_code()
                        ),
                    });
                }
                given.clone()
            }
            None => default,
        };
        self.parameter_server()?.declare(name, value, descriptor)
    }

    /// The value of parameter `name`, if it is declared.
    pub fn parameter(&self, name: &str) -> Option<ParameterValue> {
        let server = self.parameters.lock().unwrap_or_else(|e| e.into_inner());
        server.as_ref()?.value(name)
    }

    /// Set parameter `name` under the rules the parameter services apply (its
    /// descriptor, then the validation callbacks); the result says why not.
    pub fn set_parameter(&self, name: &str, value: impl Into<ParameterValue>) -> SetResult {
        self.set_parameters_atomically(&[(name.to_owned(), value.into())])
    }

    /// Set every parameter of `set`, or none.
    pub fn set_parameters_atomically(&self, set: &[(String, ParameterValue)]) -> SetResult {
        match self.parameter_server() {
            Ok(server) => server.set(set),
            Err(e) => SetResult::refused(e.to_string()),
        }
    }

    /// Validate every change of this node's parameters before it is applied,
    /// from its services or from the node itself: `Err(reason)` refuses the
    /// whole change with that reason. Runs while the parameters are locked:
    /// do not read or set this node's parameters from it.
    pub fn on_set_parameters(
        &self,
        validate: impl FnMut(&[(String, ParameterValue)]) -> Result<(), String> + Send + 'static,
    ) -> Result<(), ParameterError> {
        self.parameter_server()?.add_on_set(Box::new(validate));
        Ok(())
    }

    /// Call `callback` with every change after it was applied (same lock
    /// rule as [`on_set_parameters`](Self::on_set_parameters)).
    pub fn on_parameters_set(
        &self,
        callback: impl FnMut(&[(String, ParameterValue)]) + Send + 'static,
    ) -> Result<(), ParameterError> {
        self.parameter_server()?.add_after_set(Box::new(callback));
        Ok(())
    }

    /// The parameters of node `node` (`/ns/name`), through its services.
    pub fn parameter_client(&self, node: &str) -> zenoh::Result<ParameterClient> {
        ParameterClient::new(self, node)
    }

    /// The node's ROS clock: system time, or `/clock` while the node uses
    /// simulated time (see [`Clock`]).
    pub fn clock(&self) -> &Clock {
        &self.clock
    }

    /// Follow simulated time from `/clock` (`true`), as `use_sim_time` makes
    /// an rclcpp node do, or go back to system time; switchable at any time.
    /// The node's clock, its ROS-time timers and sleeps follow at once.
    pub fn set_use_sim_time(&self, on: bool) -> zenoh::Result<()> {
        self.sim_time_switch().set(on)
    }

    /// Call `callback` every `period` of the node's ROS time (simulated time
    /// while the node uses it), on a thread of the timer's own; see [`Timer`].
    pub fn create_timer(
        &self,
        period: std::time::Duration,
        callback: impl FnMut() + Send + 'static,
    ) -> std::io::Result<Timer> {
        Timer::start(self.clock.clone(), period, callback)
    }

    /// Call `callback` every `period` of system time, whatever the node's
    /// clock follows (rclcpp's wall timer); see [`Timer`].
    pub fn create_wall_timer(
        &self,
        period: std::time::Duration,
        callback: impl FnMut() + Send + 'static,
    ) -> std::io::Result<Timer> {
        Timer::start(Clock::new(), period, callback)
    }

    /// The live ROS graph of this node's domain, shared by every node of the
    /// session: made on first use, kept up to date by one liveliness
    /// subscriber, queried from memory (see [`GraphCache`]).
    pub fn graph_cache(&self) -> zenoh::Result<GraphCache> {
        let mut cache = self.graph.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(cache) = cache.as_ref() {
            return Ok(cache.clone());
        }
        let made = GraphCache::of(&self.session, self.info.domain_id)?;
        *cache = Some(made.clone());
        Ok(made)
    }

    /// A snapshot of the ROS graph of this node's domain: every node and
    /// endpoint whose liveliness token is alive, ours and other processes'
    /// (rmw_zenoh_cpp's included). It comes from the session's
    /// [`graph_cache`](Self::graph_cache); the first call waits up to
    /// `timeout` for the cache's first answers, later ones return at once.
    pub fn graph(&self, timeout: std::time::Duration) -> zenoh::Result<Graph> {
        let cache = self.graph_cache()?;
        cache.wait_synced(timeout);
        Ok(cache.snapshot())
    }

    /// The fully qualified name of `topic` for this node (see
    /// [`names::expand_topic_name`]): `rel` is `<namespace>/rel`, `~/x` is
    /// `<namespace>/<node>/x`; then the node's remapping rules apply.
    pub fn resolve_topic_name(&self, topic: &str) -> Result<String, NameError> {
        self.resolve_name(topic, NameKind::Topic)
    }

    /// [`resolve_topic_name`](Self::resolve_topic_name) for a service name
    /// (`rosservice://` rules apply, `rostopic://` ones do not).
    pub fn resolve_service_name(&self, service: &str) -> Result<String, NameError> {
        self.resolve_name(service, NameKind::Service)
    }

    fn resolve_name(&self, name: &str, kind: NameKind) -> Result<String, NameError> {
        resolve_name(&self.info, &self.remaps, name, kind)
    }

    /// The resolved name, or the name as given with the error that the builder
    /// reports when it is resolved.
    /// A topic endpoint's use of `T`: described by the node, and followed
    /// against the graph's endpoints of other types on the topic.
    fn topic_type_use<T: RosMessage>(&self, topic: &str) -> TypeUse {
        let type_use = self.types.register(T::type_hash(), T::full_description);
        let (resolved, invalid) = self.resolve(topic, NameKind::Topic);
        if invalid.is_some() {
            return type_use; // the builder fails with the name's error
        }
        let hash = self.info.distro.hash_field(T::type_hash());
        type_use.with_topic(self.topic_types.watch(
            self.graph_cache(),
            &resolved,
            T::TYPE_NAME,
            hash,
        ))
    }

    /// Endpoints of other processes on this node's topics whose type differs
    /// from the node's there, as the graph shows them (each once; a warning was
    /// logged for each). Such endpoints never exchange messages with the
    /// node's: their type names or type hashes (a definition from another
    /// distribution or another version of the package) differ, and both are
    /// part of the key expression.
    ///
    /// ```no_run
    /// use shm_cdr::msgs::std_msgs::String as Text;
    /// use shm_runtime::RosNode;
    /// use zenoh::Wait;
    ///
    /// let session = zenoh::open(zenoh::Config::default()).wait()?;
    /// let node = RosNode::builder(&session, "listener").wait()?;
    /// let _chatter = node.declare_subscriber::<Text>("/chatter").wait()?;
    /// for conflict in node.topic_type_conflicts() {
    ///     println!("{} on {}: {:?}, not {:?}", conflict.node, conflict.topic, conflict.theirs, conflict.ours);
    /// }
    /// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    /// ```
    pub fn topic_type_conflicts(&self) -> Vec<TypeConflict> {
        self.topic_types.conflicts()
    }

    fn resolve(&self, name: &str, kind: NameKind) -> (String, Option<NameError>) {
        resolve(&self.info, &self.remaps, name, kind)
    }

    /// What switches this node's clock between system and simulated time,
    /// apart from the node (for the `use_sim_time` parameter).
    /// Count a use of a type in the node's type-description cache, while the
    /// returned guard lives (an action server or client uses its action type,
    /// as rcl_action registers it).
    pub(crate) fn register_type(
        &self,
        hash: &str,
        describe: impl FnOnce() -> shm_cdr::describe::FullDescription,
    ) -> TypeUse {
        self.types.register(hash, describe)
    }

    /// `~/get_type_description`, answering from the node's type cache.
    fn start_type_description_service(
        &self,
    ) -> zenoh::Result<Box<dyn std::any::Any + Send + Sync>> {
        let types = self.types.clone();
        let server = self
            .declare_service::<GetTypeDescription>("~/get_type_description")
            .handler(move |request| types.answer(&request))
            .wait()?;
        Ok(Box::new(server))
    }

    /// `~/get_logger_levels` and `~/set_logger_levels`.
    fn start_logger_services(&self) -> zenoh::Result<Box<dyn std::any::Any + Send + Sync>> {
        let get = self
            .declare_service::<GetLoggerLevels>("~/get_logger_levels")
            .handler(|request| log_levels::get_levels(&request))
            .wait()?;
        let set = self
            .declare_service::<SetLoggerLevels>("~/set_logger_levels")
            .handler(|request| log_levels::set_levels(&request))
            .wait()?;
        Ok(Box::new((get, set)))
    }

    fn sim_time_switch(&self) -> SimTimeSwitch {
        SimTimeSwitch {
            session: self.session.clone(),
            info: self.info.clone(),
            remaps: self.remaps.clone(),
            types: self.types.clone(),
            clock: self.clock.clone(),
        }
    }
}

fn resolve_name(
    info: &NodeInfo,
    remaps: &Remaps,
    name: &str,
    kind: NameKind,
) -> Result<String, NameError> {
    let (node, namespace) = (&info.name, &info.namespace);
    let expanded = names::expand_topic_name(name, node, namespace)?;
    remaps.name(&expanded, kind, node, namespace)
}

fn resolve(
    info: &NodeInfo,
    remaps: &Remaps,
    name: &str,
    kind: NameKind,
) -> (String, Option<NameError>) {
    match resolve_name(info, remaps, name, kind) {
        Ok(full) => (full, None),
        Err(e) => ("/".to_owned(), Some(e)),
    }
}

/// A node's subscriber of `topic_type` on `topic` (see
/// [`RosNode::declare_subscriber_with_qos`]).
fn node_subscriber<'s, T>(
    session: &'s Session,
    info: &NodeInfo,
    remaps: &Remaps,
    topic: &str,
    qos: Qos,
    topic_type: TopicType,
    type_use: Option<TypeUse>,
) -> SubscriberBuilder<'s, T> {
    let entity_id = NEXT_ENTITY_ID.fetch_add(1, Ordering::Relaxed) + 1;
    let (topic, invalid) = resolve(info, remaps, topic, NameKind::Topic);
    let key_expr = topic_key_expr_of(info.distro, info.domain_id, &topic, &topic_type);
    let mut builder = SubscriberBuilder::new(session, key_expr, topic_type);
    builder.invalid = invalid.map(Into::into);
    builder.qos = qos;
    builder.node = Some(TopicEndpoint {
        info: info.clone(),
        entity_id,
        kind: EntityKind::Subscriber,
        topic,
    });
    builder.type_use = type_use.map(TypeUse::registered);
    builder
}

/// Switches a node's clock between system time and `/clock`.
#[derive(Clone)]
pub(crate) struct SimTimeSwitch {
    session: Session,
    info: NodeInfo,
    remaps: Remaps,
    types: Arc<TypeCache>,
    clock: Clock,
}

impl SimTimeSwitch {
    pub(crate) fn set(&self, on: bool) -> zenoh::Result<()> {
        if on == self.clock.is_simulated() {
            return Ok(());
        }
        if !on {
            self.clock.set_simulated(None);
            return Ok(());
        }
        let tick = self.clock.tick_handle();
        type ClockMsg = shm_cdr::msgs::rosgraph_msgs::msg::Clock;
        let subscription = node_subscriber::<ClockMsg>(
            &self.session,
            &self.info,
            &self.remaps,
            "/clock",
            Qos::clock(),
            TopicType::of::<ClockMsg>(),
            Some(
                self.types
                    .register(ClockMsg::type_hash(), ClockMsg::full_description),
            ),
        )
        .callback_inline(move |sample| {
            match sample.decode::<shm_cdr::msgs::rosgraph_msgs::msg::Clock>() {
                Ok(clock) => tick(RosTime::from_msg(&clock.clock)),
                Err(e) => tracing::warn!("/clock: not a rosgraph_msgs/msg/Clock: {e}"),
            }
        })
        .wait()?;
        self.clock.set_simulated(Some(subscription));
        Ok(())
    }
}

/// Builder of a [`RosNode`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct RosNodeBuilder<'a> {
    session: &'a Session,
    name: String,
    namespace: String,
    enclave: String,
    domain_id: Result<u32, NameError>,
    distro: Result<Distro, UnknownDistro>,
    shm: Option<ShmContext>,
    remaps: Remaps,
    use_sim_time: bool,
    type_description_service: bool,
    parameter_services: bool,
    logger_service: bool,
    log_levels: Vec<(String, LogLevel)>,
    overrides: ParameterOverrides,
    /// The first rule or argument that did not parse: reported by `build`.
    invalid: Option<NameError>,
    invalid_override: Option<OverrideError>,
    invalid_log_level: Option<String>,
    router_check: bool,
}

impl RosNodeBuilder<'_> {
    /// Whether building the node looks for a router or peer first, as
    /// rmw_zenoh_cpp's nodes do (default: yes; see
    /// [`rmw::config::look_for_router_once`](crate::rmw::config::look_for_router_once)).
    /// A program that checks for itself turns it off.
    pub fn router_check(mut self, on: bool) -> Self {
        self.router_check = on;
        self
    }

    /// The node's namespace (default `/`; `demo` means `/demo`).
    pub fn namespace(mut self, namespace: &str) -> Self {
        self.namespace = namespace.to_owned();
        self
    }

    /// The ROS domain (default: `ROS_DOMAIN_ID`, else 0; a `ROS_DOMAIN_ID`
    /// that is not a number makes the node's declaration fail unless this is
    /// set).
    pub fn domain_id(mut self, domain_id: u32) -> Self {
        self.domain_id = Ok(domain_id);
        self
    }

    /// The distribution whose rmw_zenoh_cpp conventions and interfaces the
    /// node speaks (default: `ROS_DISTRO`, else [`Distro::DEFAULT`]; a
    /// `ROS_DISTRO` this crate does not know makes the declaration fail
    /// unless this is set). On Humble, keys and tokens carry no type hashes
    /// and the node serves no `~/get_type_description` and no logger-level
    /// services, as a Humble node.
    pub fn distro(mut self, distro: Distro) -> Self {
        self.distro = Ok(distro);
        self
    }

    /// The node's security enclave (default `/`; `--ros-args --enclave` in
    /// [`ros_args`](Self::ros_args) sets it too), as rmw_zenoh_cpp uses it: in
    /// the node's graph tokens, where `ros2 node list`'s enclave listing
    /// finds it. The enclave's security itself is the Zenoh session's
    /// configuration (see [`rmw::config`](crate::rmw::config)). A name rcl
    /// would refuse makes the declaration fail.
    pub fn enclave(mut self, enclave: &str) -> Self {
        self.enclave = enclave.to_owned();
        self
    }

    /// Start on simulated time from `/clock` (see
    /// [`RosNode::set_use_sim_time`]).
    pub fn use_sim_time(mut self, on: bool) -> Self {
        self.use_sim_time = on;
        self
    }

    /// Whether the node serves `~/get_type_description` (default: yes, as
    /// rclcpp and rclpy nodes do; `-p start_type_description_service:=false`
    /// among the node's [`ros_args`](Self::ros_args) turns it off too). Tools
    /// such as `ros2 topic echo` ask it for the types they were not built with.
    pub fn type_description_service(mut self, on: bool) -> Self {
        self.type_description_service = on;
        self
    }

    /// Whether the node starts its parameters when it is declared (default:
    /// yes, as rclcpp's `start_parameter_services`): the six parameter
    /// services, `/parameter_events`, and the parameters every rclcpp and rclpy
    /// node has (`use_sim_time`, `start_type_description_service`), so that
    /// `ros2 param list` finds any node. Without it they start when the node
    /// first declares or sets a parameter.
    pub fn parameter_services(mut self, on: bool) -> Self {
        self.parameter_services = on;
        self
    }

    /// Whether the node serves `~/get_logger_levels` and `~/set_logger_levels`
    /// (`rcl_interfaces`), which read and change the process's
    /// [logger levels](crate::log_levels) (default: no, as rclcpp's and rclpy's
    /// `enable_logger_service`).
    pub fn logger_service(mut self, on: bool) -> Self {
        self.logger_service = on;
        self
    }

    /// The shared-memory pool the node's publishers use by default.
    pub fn shm(mut self, context: &ShmContext) -> Self {
        self.shm = Some(context.clone());
        self
    }

    /// Add a remapping rule, as `--ros-args -r` gives it: `chatter:=talk`,
    /// `talker:chatter:=talk` (this node only if it is called `talker`),
    /// `rostopic://…` / `rosservice://…` (one kind of name), `__node:=name`,
    /// `__ns:=/namespace`. Rules apply in the order added, the first match
    /// wins, as in rcl. A rule that does not parse makes the declaration fail
    /// with the reason.
    pub fn remap(mut self, rule: &str) -> Self {
        match RemapRule::parse(rule) {
            Ok(rule) => self.remaps.push(rule),
            Err(e) => {
                self.invalid.get_or_insert(e);
            }
        }
        self
    }

    /// Take a command line's ROS arguments (e.g. `std::env::args()` of a node
    /// started by `ros2 run … --ros-args -r chatter:=talk -r __ns:=/robot1` or
    /// by a launch file): the remapping rules (see
    /// [`names::ros_args_remaps`]), the parameter values (`-p`,
    /// `--params-file`) and the [logger levels](crate::log_levels)
    /// (`--log-level`, applied to the whole process when the node is
    /// declared, as rcl applies them at init).
    pub fn ros_args<I, S>(mut self, args: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: AsRef<str>,
    {
        let args: Vec<String> = args.into_iter().map(|a| a.as_ref().to_owned()).collect();
        match names::ros_args_remaps(&args) {
            Ok(rules) => rules.into_iter().for_each(|r| self.remaps.push(r)),
            Err(e) => {
                self.invalid.get_or_insert(e);
            }
        }
        match ParameterOverrides::from_ros_args(&args) {
            Ok(overrides) => self.overrides.extend(overrides),
            Err(e) => {
                self.invalid_override.get_or_insert(e);
            }
        }
        match log_levels::from_ros_args(&args) {
            Ok(levels) => self.log_levels.extend(levels),
            Err(reason) => {
                self.invalid_log_level.get_or_insert(reason);
            }
        }
        match names::ros_args_enclave(&args) {
            Ok(Some(enclave)) => self.enclave = enclave,
            Ok(None) => {}
            Err(e) => {
                self.invalid.get_or_insert(e);
            }
        }
        self
    }

    /// Initial values for the node's parameters, as `-p` and
    /// `--params-file` give them (after those of [`ros_args`](Self::ros_args);
    /// a later value wins).
    pub fn parameter_overrides(mut self, overrides: ParameterOverrides) -> Self {
        self.overrides.extend(overrides);
        self
    }

    fn build(self) -> zenoh::Result<RosNode> {
        if let Some(invalid) = self.invalid {
            return Err(invalid.into());
        }
        if let Some(invalid) = self.invalid_override {
            return Err(invalid.into());
        }
        if let Some(invalid) = self.invalid_log_level {
            return Err(invalid.into());
        }
        // Process-wide, as rcl applies them at init.
        for (name, level) in &self.log_levels {
            log_levels::set_logger_level(name, *level)
                .map_err(|e| format!("--log-level {name}: {e}"))?;
        }
        let distro = self.distro?;
        names::validate_node_name(&self.name)?;
        if self.router_check {
            crate::rmw::config::look_for_router_once(self.session);
        }
        names::validate_enclave(&self.enclave)?;
        // As rcl: the name first, then the namespace rules of the renamed node.
        let name = self.remaps.node_name(&self.name);
        let namespace = self.remaps.namespace(&name).unwrap_or(self.namespace);
        let info = NodeInfo {
            domain_id: self.domain_id?,
            zid: self.session.zid().to_string(),
            node_id: NEXT_ENTITY_ID.fetch_add(1, Ordering::Relaxed) + 1,
            enclave: self.enclave,
            namespace: names::normalize_namespace(&namespace)?,
            name,
            distro,
        };
        let node_token = info.node_token();
        check_key_expr("liveliness token", &node_token)?;
        let token = self.session.liveliness().declare_token(node_token).wait()?;
        let overrides = self.overrides.for_node(&info.fqn());
        let node = RosNode {
            overrides,
            session: self.session.clone(),
            info,
            shm: self.shm,
            remaps: self.remaps,
            graph: std::sync::Mutex::default(),
            clock: Clock::new(),
            parameters: std::sync::Mutex::default(),
            types: Arc::new(TypeCache::of(distro)),
            topic_types: TopicTypes::new(distro),
            type_description_service: None,
            logger_services: None,
            _token: token,
        };
        let mut node = node;
        let service_off = node.overrides.iter().any(|(name, value)| {
            name == START_TYPE_DESCRIPTION_SERVICE && *value == ParameterValue::Bool(false)
        });
        let type_description =
            self.type_description_service && !service_off && distro.has_type_description_service();
        if type_description {
            node.type_description_service = Some(node.start_type_description_service()?);
        }
        if self.parameter_services && !distro.has_type_description_service() {
            // Humble's nodes have `use_sim_time` alone.
            node.parameter_server()?;
        } else if self.parameter_services {
            // rclpy's and rclcpp's read-only record of whether the service runs.
            node.declare_parameter_with(
                START_TYPE_DESCRIPTION_SERVICE,
                type_description,
                ParameterDescriptor::new("If enabled, start the ~/get_type_description service.")
                    .read_only(),
            )?;
        }
        if self.logger_service && distro.has_logger_level_services() {
            node.logger_services = Some(node.start_logger_services()?);
        }
        let sim_override = node
            .overrides
            .iter()
            .any(|(name, value)| name == USE_SIM_TIME && *value == ParameterValue::Bool(true));
        if self.use_sim_time || sim_override {
            node.set_use_sim_time(true)?;
        }
        Ok(node)
    }
}

impl Resolvable for RosNodeBuilder<'_> {
    type To = zenoh::Result<RosNode>;
}

impl Wait for RosNodeBuilder<'_> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl IntoFuture for RosNodeBuilder<'_> {
    type Output = zenoh::Result<RosNode>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// The queue of a service server under `qos`: its depth, as rmw_zenoh_cpp
/// keeps requests.
fn server_history(qos: &Qos) -> crate::History {
    match qos.history {
        crate::rmw::History::KeepLast(depth) => {
            NonZeroUsize::new(depth).map_or(crate::History::KeepAll, crate::History::KeepLast)
        }
        crate::rmw::History::KeepAll => crate::History::KeepAll,
    }
}
