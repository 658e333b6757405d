//! [`ParameterClient`]: another node's parameters, through its six services.

use std::time::Duration;

use shm_cdr::msgs::rcl_interfaces::msg::{ListParametersResult, Parameter, ParameterDescriptor};
use shm_cdr::msgs::rcl_interfaces::srv::{
    DescribeParameters, DescribeParameters_Request, GetParameterTypes, GetParameterTypes_Request,
    GetParameters, GetParameters_Request, ListParameters, ListParameters_Request, SetParameters,
    SetParametersAtomically, SetParametersAtomically_Request, SetParameters_Request,
};
use zenoh::Wait;

use super::{ParameterValue, SetResult};
use crate::ros::node::RosNode;
use crate::ros::service::ServiceClient;

/// The parameters of another node (`/ns/name`), as `ros2 param` reaches
/// them: clients of its six `rcl_interfaces` services. Each call waits for
/// its reply (10 s at most, see [`ServiceClient`]); a node that is not there
/// is an error at once.
///
/// ```no_run
/// use shm_runtime::parameters::ParameterValue;
/// use shm_runtime::RosNode;
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let tool = RosNode::builder(&session, "tool").wait()?;
/// let driver = tool.parameter_client("/robot/driver")?;
/// driver.wait_for_services(std::time::Duration::from_secs(5));
/// println!("{:?}", driver.list(&[], 0)?.names);
/// let result = &driver.set(&[("max_speed".into(), ParameterValue::Double(2.0))])?[0];
/// println!("set: {} {}", result.successful, result.reason);
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
pub struct ParameterClient {
    node: String,
    list: ServiceClient<ListParameters>,
    get: ServiceClient<GetParameters>,
    types: ServiceClient<GetParameterTypes>,
    describe: ServiceClient<DescribeParameters>,
    set: ServiceClient<SetParameters>,
    set_atomically: ServiceClient<SetParametersAtomically>,
}

impl std::fmt::Debug for ParameterClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParameterClient")
            .field("node", &self.node)
            .finish()
    }
}

impl ParameterClient {
    pub(crate) fn new(from: &RosNode, node: &str) -> zenoh::Result<Self> {
        let node = node.trim_end_matches('/').to_owned();
        let service = |name: &str| format!("{node}/{name}");
        Ok(Self {
            list: from.declare_client(&service("list_parameters")).wait()?,
            get: from.declare_client(&service("get_parameters")).wait()?,
            types: from
                .declare_client(&service("get_parameter_types"))
                .wait()?,
            describe: from
                .declare_client(&service("describe_parameters"))
                .wait()?,
            set: from.declare_client(&service("set_parameters")).wait()?,
            set_atomically: from
                .declare_client(&service("set_parameters_atomically"))
                .wait()?,
            node,
        })
    }

    /// The node whose parameters these are.
    pub fn node(&self) -> &str {
        &self.node
    }

    /// Wait until the node's parameter services are there, or `timeout`
    /// passes; returns whether they are.
    pub fn wait_for_services(&self, timeout: Duration) -> bool {
        self.list.wait_for_service(timeout)
            && self.get.wait_for_service(timeout)
            && self.types.wait_for_service(timeout)
            && self.describe.wait_for_service(timeout)
            && self.set.wait_for_service(timeout)
            && self.set_atomically.wait_for_service(timeout)
    }

    /// Names under `prefixes` (all if none), down to `depth` `.`-separated
    /// levels (0: every level), with their prefixes (`ros2 param list`).
    pub fn list(&self, prefixes: &[&str], depth: u64) -> zenoh::Result<ListParametersResult> {
        let request = ListParameters_Request {
            prefixes: prefixes.iter().map(|p| (*p).to_owned()).collect(),
            depth,
        };
        Ok(self.list.call(&request).wait()?.result)
    }

    /// The values of `names`; an error naming the node if one of them is not
    /// declared there (the service then answers with none).
    pub fn get(&self, names: &[&str]) -> zenoh::Result<Vec<ParameterValue>> {
        let request = GetParameters_Request {
            names: names.iter().map(|n| (*n).to_owned()).collect(),
        };
        let values = self.get.call(&request).wait()?.values;
        if values.len() != names.len() {
            return Err(self.not_declared(names));
        }
        Ok(values.iter().map(ParameterValue::from_msg).collect())
    }

    /// The type codes of `names` (`rcl_interfaces/msg/ParameterType`).
    pub fn types(&self, names: &[&str]) -> zenoh::Result<Vec<u8>> {
        let request = GetParameterTypes_Request {
            names: names.iter().map(|n| (*n).to_owned()).collect(),
        };
        let types = self.types.call(&request).wait()?.types;
        if types.len() != names.len() {
            return Err(self.not_declared(names));
        }
        Ok(types)
    }

    /// The descriptors of `names`.
    pub fn describe(&self, names: &[&str]) -> zenoh::Result<Vec<ParameterDescriptor>> {
        let request = DescribeParameters_Request {
            names: names.iter().map(|n| (*n).to_owned()).collect(),
        };
        let descriptors = self.describe.call(&request).wait()?.descriptors;
        if descriptors.len() != names.len() {
            return Err(self.not_declared(names));
        }
        Ok(descriptors)
    }

    /// Set each of `values` on its own; one result each.
    pub fn set(&self, values: &[(String, ParameterValue)]) -> zenoh::Result<Vec<SetResult>> {
        let request = SetParameters_Request {
            parameters: parameters(values),
        };
        let results = self.set.call(&request).wait()?.results;
        Ok(results.into_iter().map(SetResult::from_msg).collect())
    }

    /// Set all of `values` or none.
    pub fn set_atomically(&self, values: &[(String, ParameterValue)]) -> zenoh::Result<SetResult> {
        let request = SetParametersAtomically_Request {
            parameters: parameters(values),
        };
        let result = self.set_atomically.call(&request).wait()?.result;
        Ok(SetResult::from_msg(result))
    }

    fn not_declared(&self, names: &[&str]) -> zenoh::Error {
        format!(
            "node {} did not answer for every one of {names:?}: one is not declared there",
            self.node
        )
        .into()
    }
}

fn parameters(values: &[(String, ParameterValue)]) -> Vec<Parameter> {
    values
        .iter()
        .map(|(name, value)| Parameter {
            name: name.clone(),
            value: value.to_msg(),
        })
        .collect()
}
