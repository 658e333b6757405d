//! Names Zenoh cannot carry are refused when the entity is declared, with an
//! error naming the limit. A key expression or liveliness token longer than
//! 65 535 bytes makes Zenoh 1.10 panic and abort the process when it sends
//! the declaration.

mod common;

use std::time::Duration;

use common::loopback_sessions;
use shm_cdr::msgs::std_msgs::String as RosString;
use shm_cdr::msgs::std_srvs::srv::Trigger;
use shm_runtime::{KeyExprTooLong, RosNode, SessionExt, MAX_KEY_EXPR_LEN};
use zenoh::Wait;

fn refused(result: zenoh::Result<impl Sized>) -> KeyExprTooLong {
    let Err(error) = result else {
        panic!("an entity Zenoh cannot carry was declared");
    };
    let too_long = error
        .downcast_ref::<KeyExprTooLong>()
        .unwrap_or_else(|| panic!("another error: {error}"))
        .clone();
    assert!(too_long.len > MAX_KEY_EXPR_LEN);
    assert!(error.to_string().contains("at most 65535"), "{error}");
    too_long
}

#[test]
fn names_longer_than_zenoh_carries_are_refused_and_the_process_goes_on() {
    let (a, b, _) = loopback_sessions();
    let long = "x".repeat(MAX_KEY_EXPR_LEN);
    let node = common::node(&a, "talker");

    let topic = format!("/{long}");
    refused(node.declare_publisher::<RosString>(&topic).wait());
    refused(node.declare_subscriber::<RosString>(&topic).wait());
    refused(
        node.declare_subscriber::<RosString>(&topic)
            .callback(|_| {})
            .wait(),
    );
    refused(node.declare_service::<Trigger>(&topic).wait());
    refused(node.declare_client::<Trigger>(&topic).wait());
    let too_long = refused(
        RosNode::builder(&a, "n")
            .namespace(&topic)
            .domain_id(0)
            .wait(),
    );
    assert_eq!(too_long.what, "liveliness token");
    refused(
        a.declare_ros_publisher::<RosString>(long.clone() + "/x")
            .wait(),
    );

    // Nothing was declared, and the session still works.
    let publisher = node.declare_publisher::<RosString>("/ok").wait().unwrap();
    let subscriber = common::node(&b, "listener")
        .declare_subscriber::<RosString>("/ok")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(Duration::from_secs(10)));
    publisher
        .publish(&RosString {
            data: "still here".into(),
        })
        .wait()
        .unwrap();
    let sample = subscriber
        .recv_timeout(Duration::from_secs(10))
        .unwrap()
        .unwrap();
    assert_eq!(sample.decode::<RosString>().unwrap().data, "still here");
}
