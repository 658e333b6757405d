//! Services between peer sessions over TCP loopback: rmw_zenoh_cpp's key,
//! attachments and tokens on the wire, every reply matched to its call under
//! concurrent clients, servers that go away or refuse, malformed requests, and
//! large requests and responses in shared memory.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use shm_cdr::interface::RosService;
use shm_cdr::msgs::rcl_interfaces::msg::{Parameter, ParameterValue, SetParametersResult};
use shm_cdr::msgs::rcl_interfaces::srv::{
    SetParameters, SetParameters_Request, SetParameters_RequestRef, SetParameters_Response,
    SetParameters_ResponseRef,
};
use shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Request, Trigger_Response};
use shm_cdr::msgs::test_msgs::srv::{BasicTypes, BasicTypes_Request, BasicTypes_Response};
use shm_runtime::rmw::{service_key_expr, Attachment, Gid};
use shm_runtime::service::CallError;
use shm_runtime::{History, RosNode, ShmConfig, ShmContext};
use zenoh::bytes::ZBytes;
use zenoh::{Session, Wait};

mod common;
use common::{loopback_sessions, node, peer_config};

const TIMEOUT: Duration = Duration::from_secs(10);

fn session_pair() -> (Session, Session, u16) {
    loopback_sessions()
}

fn echo(request: BasicTypes_Request) -> BasicTypes_Response {
    BasicTypes_Response {
        int64_value: request.int64_value + 1,
        string_value: request.string_value,
        ..Default::default()
    }
}

fn liveliness_keys(session: &Session) -> Vec<String> {
    let replies = session.liveliness().get("@ros2_lv/0/**").wait().unwrap();
    let mut keys = Vec::new();
    while let Ok(Some(reply)) = replies.recv_timeout(Duration::from_secs(2)) {
        keys.push(reply.result().unwrap().key_expr().to_string());
    }
    keys
}

#[test]
fn a_call_carries_rmw_zenoh_key_attachments_and_tokens() {
    let (a, b, _) = session_pair();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let seen = Arc::new(Mutex::new(Vec::<Attachment>::new()));
    let seen_by_server = seen.clone();
    let server = server_node
        .declare_service::<Trigger>("trigger")
        .callback(move |request| {
            let attachment = *request.attachment().expect("rmw_zenoh attachment");
            seen_by_server.lock().unwrap().push(attachment);
            let _: Trigger_Request = request.request().unwrap();
            let response = Trigger_Response {
                success: true,
                message: format!("call {}", attachment.sequence_number),
            };
            request.reply(&response).wait().unwrap();
        })
        .wait()
        .unwrap();
    assert_eq!(
        server.key_expr(),
        format!(
            "0/trigger/std_srvs::srv::dds_::Trigger_/{}",
            Trigger::type_hash()
        )
    );
    assert_eq!(
        server.key_expr(),
        service_key_expr::<Trigger>(server_node.info().distro, 0, "/trigger")
    );

    let client = client_node
        .declare_client::<Trigger>("/trigger")
        .wait()
        .unwrap();
    assert_eq!(client.key_expr(), server.key_expr());
    assert!(client.wait_for_service(TIMEOUT));
    for seq in 1..=3 {
        let reply = client.call_reply(&Trigger_Request).wait().unwrap();
        let attachment = reply.attachment().unwrap().unwrap();
        assert_eq!(attachment.sequence_number, seq);
        assert_eq!(attachment.gid, client.gid());
        let response: Trigger_Response = reply.response().unwrap();
        assert_eq!(response.message, format!("call {seq}"));
    }
    let response = client.call(&Trigger_Request).wait().unwrap();
    assert!(response.success);
    assert_eq!(response.message, "call 4");
    let seen = seen.lock().unwrap();
    assert_eq!(
        seen.iter().map(|a| a.sequence_number).collect::<Vec<_>>(),
        [1, 2, 3, 4]
    );
    assert!(seen.iter().all(|a| a.gid == client.gid()));

    // Both ends are on the ROS graph, with services' default QoS.
    let keys = liveliness_keys(&b);
    let ss = format!(
        "/SS/%/%/server/%trigger/std_srvs::srv::dds_::Trigger_/{}/::,10:,:,:,,",
        Trigger::type_hash()
    );
    let sc = ss.replace("/SS/", "/SC/").replace("/server/", "/client/");
    let server_token = keys.iter().find(|k| k.ends_with(&ss)).expect("SS token");
    let client_token = keys.iter().find(|k| k.ends_with(&sc)).expect("SC token");
    assert_eq!(server.gid(), Some(Gid::from_token(server_token)));
    assert_eq!(client.gid(), Gid::from_token(client_token));
}

#[test]
fn four_clients_a_thousand_calls_each_every_reply_is_its_own() {
    let (a, b, _) = session_pair();
    let server_node = node(&a, "echo_server");
    let _server = server_node
        .declare_service::<BasicTypes>("echo")
        .handler(echo)
        .wait()
        .unwrap();
    let client_node = node(&b, "echo_clients");
    let clients: Vec<_> = (0..4)
        .map(|_| {
            client_node
                .declare_client::<BasicTypes>("echo")
                .wait()
                .unwrap()
        })
        .collect();
    assert!(clients[0].wait_for_service(TIMEOUT));
    std::thread::scope(|scope| {
        for (c, client) in clients.iter().enumerate() {
            scope.spawn(move || {
                for i in 0..1000i64 {
                    let request = BasicTypes_Request {
                        int64_value: c as i64 * 1_000_000 + i,
                        string_value: format!("client {c} call {i}"),
                        ..Default::default()
                    };
                    let response = client.call(&request).wait().unwrap();
                    assert_eq!(response.int64_value, request.int64_value + 1);
                    assert_eq!(response.string_value, request.string_value);
                }
            });
        }
    });
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn concurrent_async_calls_to_an_async_server() {
    let (a, b, _) = session_pair();
    let server_node = node(&a, "async_server");
    let server = server_node
        .declare_service::<BasicTypes>("async_echo")
        .history(History::KeepAll)
        .await
        .unwrap();
    let serving = tokio::spawn(async move {
        server
            .serve(|request| async move {
                tokio::task::yield_now().await;
                echo(request)
            })
            .await
    });
    let client_node = node(&b, "async_client");
    let client = Arc::new(
        client_node
            .declare_client::<BasicTypes>("async_echo")
            .await
            .unwrap(),
    );
    tokio::time::timeout(TIMEOUT, client.service_available())
        .await
        .unwrap()
        .unwrap();
    let calls: Vec<_> = (0..200i64)
        .map(|i| {
            let client = client.clone();
            tokio::spawn(async move {
                let request = BasicTypes_Request {
                    int64_value: i,
                    ..Default::default()
                };
                client.call(&request).await.map(|r| (i, r.int64_value))
            })
        })
        .collect();
    for call in calls {
        let (i, answer) = call.await.unwrap().unwrap();
        assert_eq!(answer, i + 1);
    }
    serving.abort();
}

#[test]
fn a_server_gone_mid_call_ends_the_call_and_a_restarted_one_serves() {
    let (_a, b, port) = session_pair();
    let client_node = node(&b, "client");
    let client = client_node
        .declare_client::<Trigger>("restart")
        .timeout(Duration::from_secs(60))
        .wait()
        .unwrap();

    for round in 0..2 {
        let server_session = common::open(peer_config(port, false)).wait().unwrap();
        let server_node = node(&server_session, "server");
        let server = server_node
            .declare_service::<Trigger>("restart")
            .wait()
            .unwrap();
        assert!(client.wait_for_service(TIMEOUT));

        // The server takes the call, then its session goes away without a reply.
        let started = Instant::now();
        std::thread::scope(|scope| {
            let call = scope.spawn(|| client.call(&Trigger_Request).wait());
            let request = server.recv_timeout(TIMEOUT).unwrap().expect("no request");
            std::thread::sleep(Duration::from_millis(100));
            server_session.close().wait().unwrap();
            drop(request);
            let result = call.join().unwrap();
            assert!(
                matches!(result, Err(CallError::NoReply)),
                "round {round}: {result:?}"
            );
        });
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "round {round}: the client waited {:?} (its timeout is 60 s)",
            started.elapsed()
        );
    }

    // With no server at all, a call ends at once instead of waiting out its timeout.
    let started = Instant::now();
    assert!(matches!(
        client.call(&Trigger_Request).wait(),
        Err(CallError::NoReply)
    ));
    assert!(started.elapsed() < Duration::from_secs(10));

    // A restarted server serves the same client.
    let server_session = common::open(peer_config(port, false)).wait().unwrap();
    let server_node = node(&server_session, "server");
    let _server = server_node
        .declare_service::<Trigger>("restart")
        .handler(|_| Trigger_Response {
            success: true,
            message: "back".into(),
        })
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    assert_eq!(
        client.call(&Trigger_Request).wait().unwrap().message,
        "back"
    );
}

#[test]
fn malformed_requests_get_an_error_reply_and_the_server_goes_on() {
    let (a, b, _) = session_pair();
    let server_node = node(&a, "server");
    let server = server_node
        .declare_service::<BasicTypes>("strict")
        .handler(echo)
        .wait()
        .unwrap();
    let key = server.key_expr().to_owned();
    let client_node = node(&b, "client");
    let client = client_node
        .declare_client::<BasicTypes>("strict")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));

    let raw_call = |payload: Vec<u8>, attachment: Vec<u8>| -> String {
        let replies = b
            .get(&key)
            .payload(ZBytes::from(payload))
            .attachment(ZBytes::from(attachment))
            .wait()
            .unwrap();
        let reply = replies.recv_timeout(TIMEOUT).unwrap().expect("no reply");
        let error = reply.result().expect_err("an error reply");
        String::from_utf8(error.payload().to_bytes().into_owned()).unwrap()
    };
    let attachment = Attachment {
        sequence_number: 1,
        source_timestamp: 0,
        gid: Gid([7; 16]),
    }
    .to_bytes()
    .to_vec();
    // A BasicTypes request cut short after its first fields.
    let valid = shm_cdr::to_vec(&BasicTypes_Request::default()).unwrap();
    let truncated = raw_call(valid[..12].to_vec(), attachment.clone());
    assert!(
        truncated.contains("at byte 12 (in BasicTypes_Request.float64_value)"),
        "{truncated}"
    );
    // An attachment that is not rmw_zenoh's.
    let bad_attachment = raw_call(valid.clone(), vec![1, 2, 3, 4, 5]);
    assert!(bad_attachment.contains("5 bytes"), "{bad_attachment}");
    // Not even an encapsulation header.
    let empty = raw_call(Vec::new(), attachment);
    assert!(empty.contains("at byte 0"), "{empty}");
    assert_eq!(server.malformed(), 3);

    // Our client says what the server said.
    let too_long = BasicTypes_Request {
        int64_value: 41,
        ..Default::default()
    };
    assert_eq!(client.call(&too_long).wait().unwrap().int64_value, 42);
}

#[test]
fn timeouts_and_a_full_queue_are_told_to_the_client() {
    let (a, b, _) = session_pair();
    let server_node = node(&a, "busy");
    let client_node = node(&b, "client");

    // A server that never answers: the call times out, as its own error.
    let _silent = server_node
        .declare_service::<Trigger>("silent")
        .wait()
        .unwrap();
    let client = client_node
        .declare_client::<Trigger>("silent")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let started = Instant::now();
    let result = client
        .call(&Trigger_Request)
        .timeout(Duration::from_millis(300))
        .wait();
    assert!(
        matches!(result, Err(CallError::Timeout(t)) if t == Duration::from_millis(300)),
        "{result:?}"
    );
    assert!(started.elapsed() >= Duration::from_millis(300));

    // A server keeping 2 requests: the 3 pushed out get an error reply.
    let server = server_node
        .declare_service::<BasicTypes>("queue")
        .history(History::KeepLast(2.try_into().unwrap()))
        .wait()
        .unwrap();
    let client = client_node
        .declare_client::<BasicTypes>("queue")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    std::thread::scope(|scope| {
        let calls: Vec<_> = (0..5i64)
            .map(|i| {
                let client = &client;
                let call = scope.spawn(move || {
                    let request = BasicTypes_Request {
                        int64_value: i,
                        ..Default::default()
                    };
                    client.call(&request).wait()
                });
                // One after the other, so that the queue's order is known.
                let deadline = Instant::now() + TIMEOUT;
                while server.queued() + server.dropped() as usize <= i as usize {
                    assert!(Instant::now() < deadline, "request {i} never arrived");
                    std::thread::sleep(Duration::from_millis(5));
                }
                call
            })
            .collect();
        assert_eq!(server.dropped(), 3);
        for _ in 0..2 {
            let request = server.recv().unwrap();
            let response = echo(request.request().unwrap());
            request.reply(&response).wait().unwrap();
        }
        let results: Vec<_> = calls.into_iter().map(|c| c.join().unwrap()).collect();
        for (i, result) in results.iter().enumerate() {
            if i < 3 {
                assert!(
                    matches!(result, Err(CallError::Remote(why)) if why.contains("request dropped")),
                    "call {i}: {result:?}"
                );
            } else {
                assert_eq!(result.as_ref().unwrap().int64_value, i as i64 + 1);
            }
        }
    });
}

#[test]
fn large_requests_and_responses_travel_in_shared_memory() {
    let _shm = common::shm_serial();
    let (a, b, _) = session_pair();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(64 * 1024)).unwrap();
    let server_node = RosNode::builder(&a, "parameters")
        .domain_id(0)
        .shm(&shm)
        .wait()
        .unwrap();
    let client_node = RosNode::builder(&b, "client")
        .domain_id(0)
        .shm(&shm)
        .wait()
        .unwrap();
    let blob: Vec<u8> = (0..1 << 20).map(|i| (i % 251) as u8).collect();
    let expected = blob.clone();
    let _server = server_node
        .declare_service::<SetParameters>("set_parameters")
        .callback(move |request| {
            assert!(request.is_shm(), "the request should arrive in SHM");
            // Borrowed straight from the shared-memory buffer.
            let view: SetParameters_RequestRef = request.decode().unwrap();
            let bytes = view.parameters[0].value.byte_array_value;
            assert_eq!(bytes, expected.as_slice());
            let response = SetParameters_Response {
                results: vec![SetParametersResult {
                    successful: true,
                    reason: "x".repeat(200 * 1024),
                }],
            };
            request.reply(&response).wait().unwrap();
        })
        .wait()
        .unwrap();
    let client = client_node
        .declare_client::<SetParameters>("set_parameters")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let request = SetParameters_Request {
        parameters: vec![Parameter {
            name: "blob".into(),
            value: ParameterValue {
                r#type: 5,
                byte_array_value: blob,
                ..Default::default()
            },
        }],
    };
    let reply = client.call_reply(&request).wait().unwrap();
    assert!(reply.is_shm(), "the response should arrive in SHM");
    let response: SetParameters_ResponseRef = reply.decode().unwrap();
    assert!(response.results[0].successful);
    assert_eq!(response.results[0].reason.len(), 200 * 1024);
    assert_eq!(shm.stats().shm, 2);
}

#[test]
fn bad_service_names_are_refused_when_declared() {
    let (a, _b, _) = session_pair();
    let node = node(&a, "names");
    let error = node
        .declare_service::<Trigger>("a*b")
        .wait()
        .expect_err("a*b is not a service name");
    assert!(error.to_string().contains("a*b"), "{error}");
    let error = node
        .declare_client::<Trigger>("bad name")
        .wait()
        .expect_err("a space is not allowed");
    assert!(error.to_string().contains("bad name"), "{error}");
}

#[test]
fn the_graph_lists_nodes_topics_services_and_endpoints_with_qos_and_gids() {
    use shm_cdr::msgs::std_msgs;
    use shm_runtime::rmw::{EntityKind, Qos};

    let (a, b, _) = session_pair();
    let talker = RosNode::builder(&a, "talker")
        .namespace("/demo")
        .domain_id(0)
        .wait()
        .unwrap();
    let publisher = talker
        .declare_publisher_with_qos::<std_msgs::String>("chatter", Qos::transient_local(2))
        .wait()
        .unwrap();
    let server = talker.declare_service::<Trigger>("~/reset").wait().unwrap();
    let listener = node(&b, "listener");
    let _subscriber = listener
        .declare_subscriber_with_qos::<std_msgs::String>("/demo/chatter", Qos::sensor_data())
        .wait()
        .unwrap();
    let client = listener
        .declare_client::<Trigger>("/demo/talker/reset")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));

    // Seen from the listener's side: its own entities and the other session's.
    let graph = listener.graph(Duration::from_secs(2)).unwrap();
    assert_eq!(graph.unreadable().len(), 0);
    assert_eq!(graph.nodes(), ["/demo/talker", "/listener"]);
    let topics = graph.topics();
    assert_eq!(
        topics["/demo/chatter"].iter().collect::<Vec<_>>(),
        ["std_msgs/msg/String"]
    );
    assert_eq!(
        graph.services()["/demo/talker/reset"]
            .iter()
            .collect::<Vec<_>>(),
        ["std_srvs/srv/Trigger"]
    );
    let publishers = graph.publishers("/demo/chatter");
    assert_eq!(publishers.len(), 1);
    assert_eq!(publishers[0].node_fqn(), "/demo/talker");
    assert_eq!(Some(publishers[0].gid), publisher.gid());
    assert_eq!(publishers[0].zid, a.zid().to_string());
    let endpoint = publishers[0].endpoint.as_ref().unwrap();
    assert_eq!(endpoint.qos, Qos::transient_local(2));
    assert_eq!(
        endpoint.type_hash,
        <std_msgs::String as shm_cdr::RosMessage>::type_hash()
    );
    let subscribers = graph.subscribers("/demo/chatter");
    assert_eq!(subscribers.len(), 1);
    assert_eq!(
        subscribers[0].endpoint.as_ref().unwrap().qos,
        Qos::sensor_data()
    );
    let servers = graph.servers("/demo/talker/reset");
    assert_eq!(servers.len(), 1);
    assert_eq!(Some(servers[0].gid), server.gid());
    let clients = graph.endpoints(EntityKind::ServiceClient, "/demo/talker/reset");
    assert_eq!(clients.len(), 1);
    assert_eq!(clients[0].gid, client.gid());
    assert_eq!(clients[0].node_fqn(), "/listener");

    // Gone from the graph once undeclared (the undeclaration travels).
    drop(server);
    let deadline = Instant::now() + TIMEOUT;
    while !listener
        .graph(Duration::from_secs(2))
        .unwrap()
        .servers("/demo/talker/reset")
        .is_empty()
    {
        assert!(Instant::now() < deadline, "the server stayed on the graph");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A QoS given to the builder, after the node chose its endpoint, is the one
/// its graph token (and so its GID) says, as much as the one its Zenoh
/// declaration follows: ROS tools show what the endpoint does.
#[test]
fn the_qos_given_to_a_builder_is_the_one_the_graph_shows() {
    use shm_cdr::msgs::std_msgs;
    use shm_runtime::rmw::Qos;

    let (a, b, _) = session_pair();
    let talker = node(&a, "talker");
    let publisher = talker
        .declare_publisher::<std_msgs::String>("/latched")
        .qos(Qos::transient_local(3))
        .wait()
        .unwrap();
    let token = publisher.liveliness_token().unwrap().to_owned();
    assert!(
        token.ends_with(&Qos::transient_local(3).to_key_expr()),
        "{token}"
    );
    for n in 0..3 {
        publisher
            .publish(&std_msgs::String {
                data: format!("kept {n}"),
            })
            .wait()
            .unwrap();
    }
    let listener = node(&b, "listener");
    let subscriber = listener
        .declare_subscriber_with_qos::<std_msgs::String>("/latched", Qos::default())
        .qos(Qos::transient_local(3))
        .wait()
        .unwrap();
    // Transient local as the token says: the three kept messages arrive.
    for n in 0..3 {
        let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
        let message: std_msgs::String = sample.decode().unwrap();
        assert_eq!(message.data, format!("kept {n}"));
    }
    let graph = listener.graph(Duration::from_secs(2)).unwrap();
    let publishers = graph.publishers("/latched");
    assert_eq!(publishers.len(), 1);
    assert_eq!(Some(publishers[0].gid), publisher.gid());
    assert_eq!(
        publishers[0].endpoint.as_ref().unwrap().qos,
        Qos::transient_local(3)
    );
    let subscribers = graph.subscribers("/latched");
    assert_eq!(subscribers.len(), 1);
    assert_eq!(
        subscribers[0].endpoint.as_ref().unwrap().qos,
        Qos::transient_local(3)
    );
}

/// Over Zenoh's lowlatency transport (which cannot fragment), a request or a
/// response too large to travel inline is refused, not lost: the client's call
/// fails with `Unfragmentable` before anything is sent, and a server that cannot
/// send its response tells the client why. Small calls go through.
#[test]
fn lowlatency_refuses_requests_and_responses_it_cannot_carry() {
    let port = common::free_port();
    let open = |listen| {
        common::open(common::lowlatency(peer_config(port, listen)))
            .wait()
            .unwrap()
    };
    let (a, b) = (open(true), open(false));
    let _server = node(&a, "parameters")
        .declare_service::<SetParameters>("set_parameters")
        .callback(|request| {
            let view: SetParameters_RequestRef = request.decode().unwrap();
            let reason_len = view.parameters[0].value.integer_value as usize;
            let response = SetParameters_Response {
                results: vec![SetParametersResult {
                    successful: true,
                    reason: "x".repeat(reason_len),
                }],
            };
            let sent = request.reply(&response).wait();
            assert_eq!(sent.is_err(), reason_len > 64 * 1024, "{sent:?}");
        })
        .wait()
        .unwrap();
    let client = node(&b, "client")
        .declare_client::<SetParameters>("set_parameters")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let request = |blob: usize, reason: i64| SetParameters_Request {
        parameters: vec![Parameter {
            name: "blob".into(),
            value: ParameterValue {
                r#type: 5,
                integer_value: reason,
                byte_array_value: vec![1; blob],
                ..Default::default()
            },
        }],
    };

    let response = client.call(&request(1000, 1000)).wait().unwrap();
    assert_eq!(response.results[0].reason.len(), 1000);
    match client.call(&request(100 * 1024, 10)).wait() {
        Err(CallError::Unfragmentable(e)) => assert!(e.inline > 100 * 1024, "{e}"),
        other => panic!("a 100 KiB request under lowlatency: {other:?}"),
    }
    match client.call(&request(10, 100 * 1024)).wait() {
        Err(CallError::Remote(why)) => {
            assert!(why.contains("lowlatency"), "{why}")
        }
        other => panic!("a 100 KiB response under lowlatency: {other:?}"),
    }
    // The link is intact: calls still work.
    let response = client.call(&request(10, 10)).wait().unwrap();
    assert_eq!(response.results[0].reason.len(), 10);
}

/// A server of a type named at run time (as Python's nodes serve) is keyed
/// and announced as one of the compiled type: a typed client calls it, its
/// bytes in and out are the compiled types' encodings, and bytes that are
/// not CDR are the client's error reply, not a reply it would misread.
#[test]
fn a_server_of_bytes_is_keyed_announced_and_called_as_a_typed_one() {
    let (a, b, _) = session_pair();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_serialized_service("basic", BasicTypes::TYPE_NAME, BasicTypes::type_hash())
        .callback(|request| {
            let bytes = request.serialized().to_bytes().into_owned();
            let decoded: BasicTypes_Request = shm_cdr::from_bytes(&bytes).unwrap();
            if decoded.int64_value < 0 {
                // Not CDR: refused, and the client is told.
                request.reply_serialized(b"nonsense").wait().unwrap_err();
                return;
            }
            let response = shm_cdr::to_vec(&echo(decoded)).unwrap();
            request.reply_serialized(&response).wait().unwrap();
        })
        .wait()
        .unwrap();
    assert_eq!(
        server.key_expr(),
        service_key_expr::<BasicTypes>(server_node.info().distro, 0, "/basic")
    );
    let client = client_node
        .declare_client::<BasicTypes>("/basic")
        .timeout(TIMEOUT)
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    for n in [0, 41, i64::MAX - 1] {
        let request = BasicTypes_Request {
            int64_value: n,
            string_value: format!("call {n}"),
            ..Default::default()
        };
        let response = client.call(&request).wait().unwrap();
        assert_eq!(response, echo(request));
    }
    let refused = client
        .call(&BasicTypes_Request {
            int64_value: -1,
            ..Default::default()
        })
        .wait()
        .unwrap_err();
    assert!(
        matches!(&refused, CallError::Remote(why) if why.contains("CDR encapsulation header")),
        "{refused}"
    );
    let keys = liveliness_keys(&b);
    let ss = format!(
        "/SS/%/%/server/%basic/test_msgs::srv::dds_::BasicTypes_/{}/::,10:,:,:,,",
        BasicTypes::type_hash()
    );
    let token = keys.iter().find(|k| k.ends_with(&ss)).expect("SS token");
    assert_eq!(server.gid(), Some(Gid::from_token(token)));
}
