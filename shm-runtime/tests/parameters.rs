//! Parameters through their services, from another node: declared values
//! are read and set under their descriptors, a validation callback can
//! refuse, and every change is announced on `/parameter_events`. (The same
//! questions are compared with rclpy's answers in `tests/ros2/parameters.py`.)

mod common;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::loopback_sessions;
use shm_cdr::msgs::rcl_interfaces::msg::{Parameter, ParameterEvent, ParameterValue as ValueMsg};
use shm_cdr::msgs::rcl_interfaces::srv::{
    GetParameters, GetParameters_Request, SetParameters, SetParameters_Request,
};
use shm_runtime::parameters::{ParameterDescriptor, ParameterError, ParameterValue};
use shm_runtime::rmw::Qos;
use shm_runtime::RosNode;
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn another_node_reads_and_sets_parameters_under_their_descriptors() {
    let (a, b, _) = loopback_sessions();
    let node = RosNode::builder(&a, "driver")
        .namespace("/robot")
        .domain_id(0)
        .wait()
        .unwrap();
    assert_eq!(
        node.declare_parameter_with(
            "max_speed",
            1.5,
            ParameterDescriptor::new("m/s").floating_point_range(0.0, 3.0, 0.0)
        ),
        Ok(ParameterValue::Double(1.5))
    );
    assert!(matches!(
        node.declare_parameter("max_speed", 2.0),
        Err(ParameterError::AlreadyDeclared(_))
    ));
    assert!(matches!(
        node.declare_parameter_with(
            "gain",
            9i64,
            ParameterDescriptor::default().integer_range(0, 5, 0)
        ),
        Err(ParameterError::InvalidValue { .. })
    ));
    let seen = Arc::new(Mutex::new(Vec::new()));
    let applied = seen.clone();
    node.on_parameters_set(move |set| applied.lock().unwrap().extend(set.to_vec()))
        .unwrap();
    node.on_set_parameters(|set| {
        match set.iter().any(|(_, v)| *v == ParameterValue::Double(2.5)) {
            true => Err("2.5 is reserved".into()),
            false => Ok(()),
        }
    })
    .unwrap();

    let tool = common::node(&b, "tool");
    let events = tool
        .declare_subscriber_with_qos::<ParameterEvent>("/parameter_events", Qos::parameters())
        .wait()
        .unwrap();
    let set = tool
        .declare_client::<SetParameters>("/robot/driver/set_parameters")
        .wait()
        .unwrap();
    let get = tool
        .declare_client::<GetParameters>("/robot/driver/get_parameters")
        .wait()
        .unwrap();
    assert!(set.wait_for_service(TIMEOUT) && get.wait_for_service(TIMEOUT));
    assert!(events.wait_for_publishers(TIMEOUT));

    let double = |v: f64| ValueMsg {
        r#type: 3,
        double_value: v,
        ..Default::default()
    };
    let mut parameters: Vec<Parameter> = [2.0, 4.0, 2.5]
        .map(|v| Parameter {
            name: "max_speed".into(),
            value: double(v),
        })
        .to_vec();
    // A type code rcl_interfaces does not define: refused as such.
    parameters.push(Parameter {
        name: "max_speed".into(),
        value: ValueMsg {
            r#type: 255,
            ..Default::default()
        },
    });
    let request = SetParameters_Request { parameters };
    let results = set.call(&request).wait().unwrap().results;
    let outcome: Vec<(bool, &str)> = results
        .iter()
        .map(|r| (r.successful, r.reason.as_str()))
        .collect();
    assert_eq!(
        outcome,
        [
            (true, ""),
            (
                false,
                "Parameter max_speed out of range Min: 0.0, Max: 3.0, value: 4.0"
            ),
            (false, "2.5 is reserved"),
            (
                false,
                "Parameter max_speed has type 255: rcl_interfaces/msg/ParameterType defines 0 to 9"
            ),
        ]
    );
    assert_eq!(
        node.parameter("max_speed"),
        Some(ParameterValue::Double(2.0))
    );
    assert_eq!(
        *seen.lock().unwrap(),
        [("max_speed".to_owned(), ParameterValue::Double(2.0))]
    );
    let values = get
        .call(&GetParameters_Request {
            names: vec!["max_speed".into()],
        })
        .wait()
        .unwrap()
        .values;
    assert_eq!(values, [double(2.0)]);

    // Declarations made just before the tool joined may still reach it (Zenoh
    // forwards to a peer whose interests it has not learnt yet); they carry
    // only new parameters. The first change must be the one accepted.
    let event = loop {
        let event: ParameterEvent = events
            .recv_timeout(TIMEOUT)
            .unwrap()
            .expect("a parameter event")
            .decode()
            .unwrap();
        assert_eq!(event.node, "/robot/driver");
        if event.changed_parameters.is_empty() {
            assert!(event.deleted_parameters.is_empty() && !event.new_parameters.is_empty());
            continue;
        }
        break event;
    };
    assert_eq!(event.changed_parameters.len(), 1);
    assert_eq!(event.changed_parameters[0].value, double(2.0));
    // The node sets its own the same way.
    assert!(!node.set_parameter("max_speed", "fast").successful);
    assert!(node.set_parameter("max_speed", 0.5).successful);
}

#[test]
fn values_from_the_command_line_and_a_parameter_file_replace_defaults() {
    let (a, _, _) = loopback_sessions();
    let file = std::env::temp_dir().join(format!("shm_params_{}.yaml", std::process::id()));
    std::fs::write(
        &file,
        "/**:\n  ros__parameters:\n    rate: 10\n/robot/driver:\n  ros__parameters:\n    limits:\n      speed: 2.0\n    frame: odom\n",
    )
    .unwrap();
    let args = [
        "driver_bin",
        "--ros-args",
        "--params-file",
        file.to_str().unwrap(),
        "-p",
        "limits.speed:=2.5",
        "-r",
        "__ns:=/robot",
    ];
    let node = RosNode::builder(&a, "driver")
        .domain_id(0)
        .ros_args(args)
        .wait()
        .unwrap();
    // The command line's -p comes after the file: it wins.
    assert_eq!(
        node.declare_parameter("limits.speed", 1.0),
        Ok(ParameterValue::Double(2.5))
    );
    assert_eq!(node.declare_parameter("frame", "map"), Ok("odom".into()));
    assert_eq!(
        node.declare_parameter("rate", 5i64),
        Ok(ParameterValue::Integer(10))
    );
    assert_eq!(
        node.declare_parameter("untouched", true),
        Ok(ParameterValue::Bool(true))
    );
    // Of another type than the default: a clear error.
    let other = RosNode::builder(&a, "other")
        .domain_id(0)
        .ros_args(["--ros-args", "-p", "rate:=fast"])
        .wait()
        .unwrap();
    let error = other.declare_parameter("rate", 5i64).unwrap_err();
    assert!(error.to_string().contains("command line"), "{error}");
    // A value that cannot be read fails the node's declaration, saying which.
    let bad = RosNode::builder(&a, "bad")
        .domain_id(0)
        .ros_args(["--ros-args", "-p", "rate=5"])
        .wait()
        .unwrap_err();
    assert!(bad.to_string().contains("rate=5"), "{bad}");
    std::fs::remove_file(file).unwrap();
}

#[test]
fn the_use_sim_time_parameter_switches_the_nodes_clock() {
    let (a, _, _) = loopback_sessions();
    let node = common::node(&a, "sim");
    node.declare_parameter("gain", 1.0).unwrap();
    assert_eq!(
        node.parameter("use_sim_time"),
        Some(ParameterValue::Bool(false))
    );
    assert!(node.set_parameter("use_sim_time", true).successful);
    assert!(node.clock().is_simulated());
    assert!(node.set_parameter("use_sim_time", false).successful);
    assert!(!node.clock().is_simulated());
    // Given on the command line, it holds from the start.
    let started = RosNode::builder(&a, "sim2")
        .domain_id(0)
        .ros_args(["--ros-args", "-p", "use_sim_time:=true"])
        .wait()
        .unwrap();
    assert!(started.clock().is_simulated());
    started.declare_parameter("gain", 1.0).unwrap();
    assert_eq!(
        started.parameter("use_sim_time"),
        Some(ParameterValue::Bool(true))
    );
}

#[test]
fn a_parameter_client_reads_and_sets_another_nodes_parameters() {
    let (a, b, _) = loopback_sessions();
    let node = RosNode::builder(&a, "driver")
        .namespace("/robot")
        .domain_id(0)
        .wait()
        .unwrap();
    node.declare_parameter_with(
        "limits.speed",
        1.0,
        ParameterDescriptor::new("m/s").floating_point_range(0.0, 2.0, 0.0),
    )
    .unwrap();
    node.declare_parameter("frame", "base").unwrap();

    let tool = common::node(&b, "tool");
    let driver = tool.parameter_client("/robot/driver").unwrap();
    assert!(driver.wait_for_services(TIMEOUT));
    let listed = driver.list(&[], 0).unwrap();
    assert_eq!(
        listed.names,
        [
            "use_sim_time",
            "start_type_description_service",
            "limits.speed",
            "frame"
        ]
    );
    assert_eq!(listed.prefixes, ["limits"]);
    assert_eq!(
        driver.get(&["frame", "limits.speed"]).unwrap(),
        [ParameterValue::from("base"), ParameterValue::Double(1.0)]
    );
    let missing = driver.get(&["frame", "nope"]).unwrap_err();
    assert!(missing.to_string().contains("/robot/driver"), "{missing}");
    assert_eq!(driver.types(&["frame"]).unwrap(), [4]);
    assert_eq!(
        driver.describe(&["limits.speed"]).unwrap()[0].description,
        "m/s"
    );
    let results = driver
        .set(&[
            ("limits.speed".into(), ParameterValue::Double(1.5)),
            ("limits.speed".into(), ParameterValue::Double(5.0)),
        ])
        .unwrap();
    assert_eq!(
        results.iter().map(|r| r.successful).collect::<Vec<_>>(),
        [true, false]
    );
    assert!(
        !driver
            .set_atomically(&[
                ("frame".into(), "odom".into()),
                ("limits.speed".into(), ParameterValue::Integer(1)),
            ])
            .unwrap()
            .successful
    );
    assert_eq!(node.parameter("frame"), Some("base".into()));
    assert_eq!(
        node.parameter("limits.speed"),
        Some(ParameterValue::Double(1.5))
    );
}
