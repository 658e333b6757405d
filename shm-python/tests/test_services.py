"""Service clients from Python: the parameter services of a node in another
process (served by our Rust runtime) called with standard service types."""

import pytest

import shm_cdr
from conftest import HUB, run_python, session_env

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
