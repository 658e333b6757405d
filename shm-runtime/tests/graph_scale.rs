//! The graph at a realistic size: more liveliness tokens than Zenoh's default
//! channel holds (256) must neither hang a graph query nor a wait for
//! publishers (rclcpp nodes announce about ten endpoints each, so 26 nodes
//! pass 256).

mod common;

use std::time::{Duration, Instant};

use common::loopback_sessions;
use shm_cdr::msgs::std_msgs::String as RosString;
use shm_runtime::RosNode;
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn a_graph_of_300_nodes_and_600_publishers_is_read_within_its_timeout() {
    let (a, b, _) = loopback_sessions();
    let nodes: Vec<RosNode> = (0..300)
        .map(|i| common::node(&a, &format!("node_{i}")))
        .collect();
    let publishers: Vec<_> = nodes
        .iter()
        .flat_map(|node| {
            ["rosout", "chatter"]
                .map(|topic| node.declare_publisher::<RosString>(topic).wait().unwrap())
        })
        .collect();
    let observer = common::node(&b, "observer");
    let started = Instant::now();
    // Tokens travel to the other session; wait until all 901 nodes' and
    // publishers' tokens are seen, each query bounded by its timeout.
    loop {
        let graph = observer.graph(Duration::from_secs(2)).unwrap();
        assert!(
            started.elapsed() < TIMEOUT + Duration::from_secs(3),
            "graph() ran past its timeout"
        );
        if graph.nodes().len() == 301
            && graph.publishers("/rosout").len() == 300
            && graph.publishers("/chatter").len() == 300
        {
            break;
        }
        assert!(
            started.elapsed() < TIMEOUT,
            "not all seen: {} nodes",
            graph.nodes().len()
        );
    }
    println!(
        "graph: 301 nodes, 600 publishers read in {:?}",
        started.elapsed()
    );
    drop(publishers);
}

#[test]
fn waiting_for_the_publishers_of_a_topic_with_300_of_them_returns() {
    let (a, b, _) = loopback_sessions();
    let nodes: Vec<RosNode> = (0..300)
        .map(|i| common::node(&a, &format!("talker_{i}")))
        .collect();
    let _publishers: Vec<_> = nodes
        .iter()
        .map(|node| {
            node.declare_publisher::<RosString>("/rosout")
                .wait()
                .unwrap()
        })
        .collect();
    let listener = common::node(&b, "listener")
        .declare_subscriber::<RosString>("/rosout")
        .wait()
        .unwrap();
    let started = Instant::now();
    assert!(listener.wait_for_publishers(TIMEOUT));
    assert!(started.elapsed() < TIMEOUT);
}
