"""Services from Python: clients calling the parameter services of a node in
another process (served by our Rust runtime), and servers answered by a
Python callback, called from Python and from our Rust command line."""

import subprocess

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
