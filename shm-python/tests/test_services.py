"""Services from Python: clients calling the parameter services of a node in
another process (served by our Rust runtime), and servers answered by a
Python callback, called from Python and from our Rust command line."""

import subprocess
import sys
import textwrap

import pytest

import shm_cdr
from conftest import HUB, run_python, session_env, shm_ros2

SERVER = """
import time
import shm_cdr

node = shm_cdr.Node("server", namespace="/svc")
node.declare_parameter("answer", 42)
node.declare_parameter("names", ["a", "b"])
print("ready", flush=True)
time.sleep(60)
"""


@pytest.fixture(scope="module")
def server():
    proc = run_python(SERVER, session_env(connect=HUB))
    assert proc.stdout.readline().strip() == "ready", proc.stderr.read()
    yield proc
    proc.kill()


def test_a_standard_service_type_has_its_request_and_response():
    srv = shm_cdr.service_type("rcl_interfaces/srv/GetParameters")
    assert srv.name == "rcl_interfaces/srv/GetParameters"
    assert srv.hash.startswith("RIHS01_")
    assert srv.Request.name == "rcl_interfaces/srv/GetParameters_Request"
    assert "names" in srv.Request.get_fields_and_field_types()
    assert shm_cdr.service_type("rcl_interfaces/GetParameters").hash == srv.hash
    with pytest.raises(LookupError):
        shm_cdr.service_type("my_srvs/srv/Nothing")


def test_a_client_calls_another_process_s_parameter_service(server):
    from test_pubsub import this_node

    client = this_node().create_client("rcl_interfaces/srv/GetParameters", "/svc/server/get_parameters")
    assert client.wait_for_service(timeout_sec=20.0)
    response = client.call({"names": ["answer", "names"]})
    assert response.type_name == "rcl_interfaces/srv/GetParameters_Response"
    answer, names = response.values
    assert (answer.type, answer.integer_value) == (2, 42)
    assert (names.type, names.string_array_value) == (9, ["a", "b"])
    request = client.srv_type.Request(names=["answer"])
    assert client.call(request).values[0].integer_value == 42
    with pytest.raises(TypeError, match="GetParameters_Request"):
        client.call(5)


def test_waiting_for_a_service_nobody_serves_returns_false():
    from test_pubsub import this_node

    client = this_node().create_client("std_srvs/srv/Trigger", "/nobody/here")
    assert not client.wait_for_service(timeout_sec=0.5)
    assert not client.service_is_ready()


ADDER = """
import time
import shm_cdr

node = shm_cdr.Node("add_two_ints_server")

def add(request, response):
    if request.a == 13:
        raise ValueError("unlucky")
    if request.a == 7:
        return {"sum": 700}
    if request.a == 8:
        return None
    response.sum = request.a + request.b
    return response

server = node.create_service("example_interfaces/srv/AddTwoInts", "/add_two_ints", add)
assert server.srv_type.name == "example_interfaces/srv/AddTwoInts"
print("ready", server.key_expr, flush=True)
deadline = time.monotonic() + 60
while time.monotonic() < deadline:
    try:
        shm_cdr.spin(timeout_sec=1.0)
    except (TypeError, ValueError) as e:
        print("spin raised", type(e).__name__, e, flush=True)
"""


@pytest.fixture(scope="module")
def adder():
    proc = run_python(ADDER, session_env(connect=HUB))
    line = proc.stdout.readline().split()
    assert line[:1] == ["ready"], proc.stderr.read()
    # Keyed as rmw_zenoh_cpp keys a server of that type: domain, name, type, hash.
    assert line[1].startswith("0/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/RIHS01_"), line
    yield proc
    proc.kill()


def test_a_python_server_answers_as_its_callback_says(adder):
    from test_pubsub import this_node

    client = this_node().create_client("example_interfaces/srv/AddTwoInts", "/add_two_ints")
    assert client.wait_for_service(timeout_sec=20.0)
    for a, b in [(2, 3), (-5, 1), (2**62, 2**62 - 1)]:
        response = client.call({"a": a, "b": b})
        assert response.type_name == "example_interfaces/srv/AddTwoInts_Response"
        assert response.sum == a + b
    # A dict of the response's fields is a response too.
    assert client.call(client.srv_type.Request(a=7, b=0)).sum == 700


def test_our_rust_command_line_calls_a_python_server(adder):
    cli = shm_ros2()
    call = subprocess.run(
        [cli, "service", "call", "/add_two_ints", "example_interfaces/srv/AddTwoInts",
         "{a: 2, b: 40}"],
        env=session_env(connect=HUB), capture_output=True, text=True, timeout=60,
    )
    assert call.returncode == 0, call.stderr
    assert "example_interfaces.srv.AddTwoInts_Response(sum=42)" in call.stdout
    listed = subprocess.run(
        [cli, "service", "list", "-t"],
        env=session_env(connect=HUB), capture_output=True, text=True, timeout=60,
    )
    assert "/add_two_ints [example_interfaces/srv/AddTwoInts]" in listed.stdout, listed.stdout


def test_a_callback_that_fails_is_the_client_s_error_and_spin_raises_it(adder):
    from test_pubsub import this_node

    client = this_node().create_client("example_interfaces/srv/AddTwoInts", "/add_two_ints")
    assert client.wait_for_service(timeout_sec=20.0)
    with pytest.raises(shm_cdr.ShmCdrError, match="returned None: return the response"):
        client.call({"a": 8, "b": 0})
    with pytest.raises(shm_cdr.ShmCdrError, match="the service callback raised ValueError: unlucky"):
        client.call({"a": 13, "b": 0})
    # The server goes on answering, and its `spin` raised both.
    assert client.call({"a": 1, "b": 1}).sum == 2
    adder.kill()
    raised = adder.stdout.read().splitlines()
    assert raised == [
        "spin raised TypeError the callback of a server of example_interfaces/srv/AddTwoInts"
        " returned None: return the response",
        "spin raised ValueError unlucky",
    ]


def test_a_server_of_an_unknown_type_is_refused():
    from test_pubsub import this_node

    with pytest.raises(LookupError, match="my_srvs/srv/Nothing"):
        this_node().create_service("my_srvs/srv/Nothing", "/x", lambda req, resp: resp)
    with pytest.raises(TypeError, match="ServiceType"):
        this_node().create_service(5, "/x", lambda req, resp: resp)


def robot_interfaces(root):
    """A package of our own with a message and a service, as a user writes
    them (the service uses the message)."""
    pkg = root / "robot_interfaces"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "srv").mkdir()
    (pkg / "msg" / "Joint.msg").write_text("string name\nfloat64 position\n")
    (pkg / "srv" / "MoveArm.srv").write_text(
        "# Move every joint named.\nrobot_interfaces/Joint[] joints\nfloat32 speed 0.5\n---\n"
        "bool reached\nstring message\n"
    )
    return str(root)


OWN_SERVER = """
import sys, time
import shm_cdr

interfaces = [sys.argv[1]]
node = shm_cdr.Node("arm")
MoveArm = shm_cdr.service_type("robot_interfaces/srv/MoveArm", interfaces=interfaces)
Joint = shm_cdr.message_type("robot_interfaces/msg/Joint", interfaces=interfaces)

def move(request, response):
    response.reached = all(j.position < 3.0 for j in request.joints)
    response.message = ",".join(j.name for j in request.joints) + f" at {request.speed}"
    return response

server = node.create_service(MoveArm, "/arm/move", move)
pub = node.create_publisher(Joint, "/arm/joint")
print("ready", MoveArm.hash, flush=True)
deadline = time.monotonic() + 60
while time.monotonic() < deadline:
    pub.publish({"name": "elbow", "position": 1.5})
    time.sleep(0.05)
"""


def test_services_of_our_own_srv_files(tmp_path):
    from test_pubsub import this_node

    interfaces = robot_interfaces(tmp_path)
    MoveArm = shm_cdr.service_type("robot_interfaces/MoveArm", interfaces=[interfaces])
    assert MoveArm.name == "robot_interfaces/srv/MoveArm"
    assert MoveArm.hash.startswith("RIHS01_")
    assert MoveArm.Request.get_fields_and_field_types() == {
        "joints": "sequence<robot_interfaces/Joint>", "speed": "float",
    }
    assert MoveArm.Request().speed == 0.5
    with pytest.raises(LookupError, match="interfaces="):
        shm_cdr.service_type("robot_interfaces/srv/Nothing", interfaces=[interfaces])

    server = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(OWN_SERVER), interfaces],
        env=session_env(connect=HUB), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        line = server.stdout.readline().split()
        assert line[:1] == ["ready"], server.stderr.read()
        assert line[1] == MoveArm.hash
        client = this_node().create_client(MoveArm, "/arm/move")
        assert client.wait_for_service(timeout_sec=20.0)
        response = client.call({"joints": [{"name": "shoulder", "position": 0.5},
                                           {"name": "wrist", "position": 2.0}]})
        assert response.reached
        assert response.message == "shoulder,wrist at 0.5"

        # A node that knows neither type by name learns both from the graph
        # and the serving node's type-description service.
        Joint = this_node().get_topic_type("/arm/joint", timeout_sec=20.0)
        assert Joint.name == "robot_interfaces/msg/Joint"
        assert Joint.hash == shm_cdr.message_type(
            "robot_interfaces/msg/Joint", interfaces=[interfaces]).hash
        sub = this_node().create_subscription(Joint, "/arm/joint")
        msg = sub.recv(timeout=20.0)
        assert (msg.name, msg.position) == ("elbow", 1.5)
        served = this_node().get_service_type("/arm/move", timeout_sec=20.0)
        assert served.name == "robot_interfaces/srv/MoveArm"
        assert served.hash == MoveArm.hash
        # Served again with the type learned: this node describes it in turn.
        relay = this_node().create_service(served, "/relay/move", lambda req, resp: resp)
        again = this_node().get_service_type("/relay/move", timeout_sec=20.0)
        assert again.hash == MoveArm.hash
        assert this_node().destroy_service(relay)
    finally:
        server.kill()


def test_types_of_what_is_not_there_say_so():
    from test_pubsub import this_node

    with pytest.raises(shm_cdr.ShmCdrError, match="no publishers or subscribers"):
        this_node().get_topic_type("/nobody/publishes", timeout_sec=0.2)
    with pytest.raises(shm_cdr.ShmCdrError, match="has no server"):
        this_node().get_service_type("/nobody/serves", timeout_sec=0.2)
    with pytest.raises(ValueError, match="timeout_sec"):
        this_node().get_topic_type("/x", timeout_sec=-1.0)
