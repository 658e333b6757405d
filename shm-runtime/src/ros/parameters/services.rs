//! The six `rcl_interfaces` parameter services of a node and its
//! `/parameter_events`, as rclpy serves and publishes them.

use std::any::Any;
use std::sync::{Arc, Mutex, MutexGuard};

use shm_cdr::msgs::rcl_interfaces::msg::{Parameter, ParameterEvent};
use shm_cdr::msgs::rcl_interfaces::srv::{
    DescribeParameters, DescribeParameters_Response, GetParameterTypes, GetParameterTypes_Response,
    GetParameters, GetParameters_Response, ListParameters, ListParameters_Response, SetParameters,
    SetParametersAtomically, SetParametersAtomically_Response, SetParameters_Response,
};
use zenoh::Wait;

use super::store::{AfterSet, Changes, OnSet, SetResult, Store};
use super::{ParameterDescriptor, ParameterError, ParameterValue};
use crate::rmw::Qos;
use crate::ros::node::RosNode;
use crate::ros::time::Clock;
use crate::RosPublisher;

/// What the services and the node's own calls share.
struct Shared {
    store: Mutex<Store>,
    events: RosPublisher<ParameterEvent>,
    /// The node's fully qualified name, as events carry it.
    node: String,
    clock: Clock,
}

impl Shared {
    fn store(&self) -> MutexGuard<'_, Store> {
        // The store is whole between statements.
        self.store.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn publish(&self, changes: Changes) {
        if changes.is_empty() {
            return;
        }
        let event = ParameterEvent {
            stamp: self.clock.now().to_msg(),
            node: self.node.clone(),
            new_parameters: changes.new,
            changed_parameters: changes.changed,
            deleted_parameters: changes.deleted,
        };
        if let Err(e) = self.events.publish(&event).wait() {
            tracing::warn!("/parameter_events: {e}");
        }
    }

    fn set(&self, set: &[(String, ParameterValue)]) -> SetResult {
        let (result, changes) = self.store().set_atomically(set);
        self.publish(changes);
        result
    }

    /// A set asked through the services.
    fn set_msgs(&self, set: &[Parameter]) -> SetResult {
        // A type code rcl_interfaces does not define is refused as such,
        // not read as "not set" (which would undeclare the parameter).
        if let Some(p) = set.iter().find(|p| p.value.r#type > MAX_TYPE_CODE) {
            return SetResult::refused(format!(
                "Parameter {} has type {}: rcl_interfaces/msg/ParameterType defines 0 to \
                 {MAX_TYPE_CODE}",
                shm_cdr::text_limits::quoted(&p.name),
                p.value.r#type
            ));
        }
        let set: Vec<(String, ParameterValue)> = set
            .iter()
            .map(|p| (p.name.clone(), ParameterValue::from_msg(&p.value)))
            .collect();
        self.set(&set)
    }
}

/// The highest type code of `rcl_interfaces/msg/ParameterType`
/// (`PARAMETER_STRING_ARRAY`).
const MAX_TYPE_CODE: u8 = 9;

/// A node's parameters with their services, started with the node (or, with
/// `parameter_services(false)`, on first use).
pub(crate) struct ParameterServer {
    shared: Arc<Shared>,
    _services: Vec<Box<dyn Any + Send + Sync>>,
}

impl ParameterServer {
    pub(crate) fn start(node: &RosNode) -> zenoh::Result<Self> {
        let events = node
            .declare_publisher_with_qos::<ParameterEvent>("/parameter_events", Qos::parameters())
            .wait()?;
        let fqn = node.info().fqn();
        let shared = Arc::new(Shared {
            store: Mutex::new(Store::for_distro(node.info().distro)),
            events,
            node: fqn,
            clock: node.clock().clone(),
        });
        let mut services: Vec<Box<dyn Any + Send + Sync>> = Vec::new();
        let s = shared.clone();
        services.push(Box::new(
            node.declare_service::<ListParameters>("~/list_parameters")
                .handler(move |request| ListParameters_Response {
                    result: s.store().list(&request.prefixes, request.depth),
                })
                .wait()?,
        ));
        let s = shared.clone();
        services.push(Box::new(
            node.declare_service::<GetParameters>("~/get_parameters")
                .handler(move |request| GetParameters_Response {
                    values: s.store().get(&request.names),
                })
                .wait()?,
        ));
        let s = shared.clone();
        services.push(Box::new(
            node.declare_service::<GetParameterTypes>("~/get_parameter_types")
                .handler(move |request| GetParameterTypes_Response {
                    types: s.store().types(&request.names),
                })
                .wait()?,
        ));
        let s = shared.clone();
        services.push(Box::new(
            node.declare_service::<DescribeParameters>("~/describe_parameters")
                .handler(move |request| DescribeParameters_Response {
                    descriptors: s.store().describe(&request.names),
                })
                .wait()?,
        ));
        let s = shared.clone();
        services.push(Box::new(
            node.declare_service::<SetParameters>("~/set_parameters")
                // One at a time, each on its own, as rclpy answers.
                .handler(move |request| SetParameters_Response {
                    results: request
                        .parameters
                        .iter()
                        .map(|one| s.set_msgs(std::slice::from_ref(one)).to_msg())
                        .collect(),
                })
                .wait()?,
        ));
        let s = shared.clone();
        services.push(Box::new(
            node.declare_service::<SetParametersAtomically>("~/set_parameters_atomically")
                .handler(move |request| SetParametersAtomically_Response {
                    result: s.set_msgs(&request.parameters).to_msg(),
                })
                .wait()?,
        ));
        Ok(Self {
            shared,
            _services: services,
        })
    }

    pub(crate) fn declare(
        &self,
        name: &str,
        value: ParameterValue,
        descriptor: ParameterDescriptor,
    ) -> Result<ParameterValue, ParameterError> {
        let changes = self
            .shared
            .store()
            .declare(name, value.clone(), descriptor)?;
        self.shared.publish(changes);
        Ok(value)
    }

    pub(crate) fn value(&self, name: &str) -> Option<ParameterValue> {
        self.shared.store().value(name)
    }

    pub(crate) fn set(&self, set: &[(String, ParameterValue)]) -> SetResult {
        self.shared.set(set)
    }

    pub(crate) fn add_on_set(&self, callback: OnSet) {
        self.shared.store().add_on_set(callback);
    }

    pub(crate) fn add_after_set(&self, callback: AfterSet) {
        self.shared.store().add_after_set(callback);
    }
}
