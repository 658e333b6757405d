//! What a tool that was not built with a type does: find the type's hash on
//! the graph, ask the publishing node's `~/get_type_description` for it, build
//! a run-time type from the reply (`shm_cdr::dynamic`), and read the topic's
//! messages with it. The reply's hash is the one in the tokens; a type leaves
//! the answers when the last entity using it goes.

mod common;

use std::time::Duration;

use common::loopback_sessions;
use shm_cdr::dynamic::{DynamicType, Value};
use shm_cdr::msgs::sensor_msgs::Imu;
use shm_cdr::msgs::std_msgs::Header;
use shm_cdr::msgs::type_description_interfaces::srv::{
    GetTypeDescription, GetTypeDescription_Request,
};
use shm_cdr::RosMessage;
use shm_runtime::rmw::{EntityKind, Qos};
use shm_runtime::RosNode;
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn a_tool_reads_a_topic_through_the_publishers_type_description() {
    let (a, b, _) = loopback_sessions();
    let driver = RosNode::builder(&a, "imu_driver")
        .namespace("/robot")
        .domain_id(0)
        .wait()
        .unwrap();
    let imu = driver.declare_publisher::<Imu>("imu").wait().unwrap();

    let tool = common::node(&b, "echo");
    // The graph says who publishes /robot/imu and with which type hash.
    let graph = tool.graph_cache().unwrap();
    assert!(graph.wait_until(TIMEOUT, |g| !g.publishers("/robot/imu").is_empty()));
    let publisher = graph.read().publishers("/robot/imu")[0].clone();
    let endpoint = publisher.endpoint.clone().unwrap();
    assert_eq!(publisher.node_fqn(), "/robot/imu_driver");

    let client = tool
        .declare_client::<GetTypeDescription>("/robot/imu_driver/get_type_description")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let ask = |hash: &str| {
        client
            .call(&GetTypeDescription_Request {
                type_name: endpoint.type_name.clone(),
                type_hash: hash.to_owned(),
                include_type_sources: true,
            })
            .wait()
            .unwrap()
    };
    let reply = ask(&endpoint.type_hash);
    assert!(reply.successful, "{}", reply.failure_reason);
    assert_eq!(reply.type_sources[0].type_name, "sensor_msgs/msg/Imu");
    assert!(reply.type_sources[0]
        .raw_file_contents
        .contains("geometry_msgs/Quaternion orientation"));
    let ty = DynamicType::from_type_description_msg(&reply.type_description).unwrap();
    assert_eq!(ty.type_hash(), endpoint.type_hash);
    assert_eq!(ty.name(), endpoint.type_name);

    // Messages on the topic read with the run-time type.
    let listener = tool
        .declare_dynamic_subscriber("/robot/imu", &ty, Qos::default())
        .wait()
        .unwrap();
    assert!(imu.wait_for_subscribers(TIMEOUT));
    let sent = Imu {
        header: Header {
            frame_id: "imu_link".into(),
            ..Default::default()
        },
        linear_acceleration_covariance: [0.5; 9],
        ..Default::default()
    };
    imu.publish(&sent).wait().unwrap();
    let sample = listener.recv_timeout(TIMEOUT).unwrap().expect("a sample");
    let bytes = sample.payload().to_bytes();
    let message = ty.decode(&bytes).unwrap();
    let Some(header) = message.message("header") else {
        panic!("no header in {message:?}");
    };
    assert_eq!(
        header.value("frame_id"),
        Some(&Value::String("imu_link".into()))
    );
    assert_eq!(
        message.value("linear_acceleration_covariance"),
        Some(&Value::F64s(vec![0.5; 9].into()))
    );
    assert_eq!(
        shm_cdr::to_vec(&message).unwrap(),
        shm_cdr::to_vec(&sent).unwrap()
    );

    // The type leaves the answers with the publisher.
    drop(imu);
    let gone = ask(&endpoint.type_hash);
    assert!(!gone.successful);
    assert_eq!(
        gone.failure_reason,
        "Type not currently in use by this node"
    );
    assert_eq!(Imu::type_hash(), endpoint.type_hash);
}

#[test]
fn run_time_typed_endpoints_are_the_compiled_types_endpoints() {
    let (a, b, _) = loopback_sessions();
    let typed = common::node(&a, "typed");
    let tool = common::node(&b, "tool");
    let ty = DynamicType::from_description(&Header::full_description()).unwrap();

    // A run-time typed publisher reaches a compiled subscriber, with the
    // token a compiled publisher would have (type name, hash, QoS).
    let subscriber = typed
        .declare_subscriber::<Header>("/stamps")
        .wait()
        .unwrap();
    let publisher = tool
        .declare_dynamic_publisher("/stamps", &ty, Qos::default())
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    let message = ty
        .message_from_yaml("{stamp: {sec: 5, nanosec: 6}, frame_id: odom}")
        .unwrap();
    publisher.publish_dynamic(&message).wait().unwrap();
    let received = subscriber.recv_timeout(TIMEOUT).unwrap().expect("a sample");
    let header: Header = received.decode().unwrap();
    assert_eq!(
        (
            header.stamp.sec,
            header.stamp.nanosec,
            header.frame_id.as_str()
        ),
        (5, 6, "odom")
    );

    let graph = typed.graph_cache().unwrap();
    assert!(graph.wait_until(TIMEOUT, |g| !g.publishers("/stamps").is_empty()));
    let entity = graph.read().publishers("/stamps")[0].clone();
    assert_eq!(entity.kind, EntityKind::Publisher);
    let endpoint = entity.endpoint.clone().unwrap();
    assert_eq!(endpoint.type_name, Header::TYPE_NAME);
    assert_eq!(endpoint.type_hash, Header::type_hash());

    // A message of another type is refused, not sent.
    let other = DynamicType::from_description(&Imu::full_description()).unwrap();
    let wrong = other.default_message();
    let error = publisher.publish_dynamic(&wrong).wait().unwrap_err();
    assert_eq!(
        error.to_string(),
        "publish: a sensor_msgs/msg/Imu message on a publisher of std_msgs/msg/Header"
    );
    // A nested message of the right type is not the type itself either.
    let Some(stamp) = message.message("stamp") else {
        panic!("no stamp")
    };
    assert!(publisher
        .publish_dynamic(&stamp.to_message())
        .wait()
        .is_err());
    assert!(subscriber
        .recv_timeout(Duration::from_millis(300))
        .unwrap()
        .is_none());
}

/// A node describes the types of its run-time typed endpoints as it does
/// compiled ones: the same description, with `.msg` text written back from
/// the type, or the interface files' own text where it is given.
#[test]
fn run_time_typed_endpoints_are_described_by_their_node() {
    use shm_cdr::msgs::test_msgs::msg::{BoundedSequences, Defaults};
    for full in [
        Imu::full_description(),
        Header::full_description(),
        Defaults::full_description(),
        BoundedSequences::full_description(),
    ] {
        let ty = DynamicType::from_description(&full).unwrap();
        assert_eq!(
            ty.to_type_description_msg(),
            (&full).into(),
            "{}",
            ty.name()
        );
    }

    let (a, b, _) = loopback_sessions();
    let owner = common::node(&a, "dynamic");
    let tool = common::node(&b, "tool");
    let imu = DynamicType::from_description(&Imu::full_description()).unwrap();
    let header = DynamicType::from_description(&Header::full_description()).unwrap();
    let own_text = "# As the package's file has it.\nstd_msgs/Header header\n";
    let publisher = owner
        .declare_dynamic_publisher("/imu", &imu, Qos::default())
        .type_sources([("sensor_msgs/msg/Imu", own_text)])
        .wait()
        .unwrap();
    let subscriber = owner
        .declare_dynamic_subscriber("/stamps", &header, Qos::default())
        .wait()
        .unwrap();

    let client = tool
        .declare_client::<GetTypeDescription>("/dynamic/get_type_description")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let ask = |ty: &DynamicType| {
        client
            .call(&GetTypeDescription_Request {
                type_name: ty.name().to_owned(),
                type_hash: ty.type_hash(),
                include_type_sources: true,
            })
            .wait()
            .unwrap()
    };
    let reply = ask(&imu);
    assert!(reply.successful, "{}", reply.failure_reason);
    assert_eq!(reply.type_description, (&Imu::full_description()).into());
    let source = |name: &str| {
        reply
            .type_sources
            .iter()
            .find(|s| s.type_name == name)
            .map(|s| s.raw_file_contents.clone())
    };
    assert_eq!(source("sensor_msgs/msg/Imu").as_deref(), Some(own_text));
    // Not given: written back from the type.
    let written = source("geometry_msgs/msg/Quaternion").unwrap();
    assert!(written.starts_with("float64 x 0.0\n"), "{written}");

    let reply = ask(&header);
    assert!(reply.successful, "{}", reply.failure_reason);
    assert_eq!(reply.type_description, (&Header::full_description()).into());

    drop(publisher);
    drop(subscriber);
    assert!(!ask(&imu).successful);
    assert!(!ask(&header).successful);
}

/// A server of a service typed at run time describes the service as a
/// server of the compiled type does (its request, response and event
/// included), for as long as it serves.
#[test]
fn a_run_time_typed_service_server_is_described_by_its_node() {
    use shm_cdr::interface::RosService;
    use shm_cdr::msgs::test_msgs::srv::BasicTypes;

    let (a, b, _) = loopback_sessions();
    let owner = common::node(&a, "dynamic_server");
    let tool = common::node(&b, "tool");
    let service = DynamicType::from_description(&BasicTypes::full_description()).unwrap();
    assert_eq!(service.type_hash(), BasicTypes::type_hash());
    let server = owner
        .declare_dynamic_service("/basic", &service)
        .callback(|request| request.reply_err("not this time"))
        .wait()
        .unwrap();
    let client = tool
        .declare_client::<GetTypeDescription>("/dynamic_server/get_type_description")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let ask = || {
        client
            .call(&GetTypeDescription_Request {
                type_name: BasicTypes::TYPE_NAME.to_owned(),
                type_hash: BasicTypes::type_hash().to_owned(),
                include_type_sources: false,
            })
            .wait()
            .unwrap()
    };
    let reply = ask();
    assert!(reply.successful, "{}", reply.failure_reason);
    assert_eq!(
        reply.type_description,
        (&BasicTypes::full_description()).into()
    );
    drop(server);
    assert!(!ask().successful);
}
