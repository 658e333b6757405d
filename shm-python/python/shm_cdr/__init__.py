"""ROS 2 messages through Zenoh shared memory, on rmw_zenoh_cpp's wire.

Nodes, publishers, subscriptions, service servers and clients of any ROS 2
interface: the standard set built in, your own ``.msg`` files
(``message_type(name, interfaces=[...])``).
A received message's arrays of numbers are numpy arrays that view the sample
where it arrived (in shared memory when it came through it), read-only; a
``Publisher.loan`` lends the buffer a message is sent from, its arrays
writable numpy arrays there, so that publishing copies none of them.

The process's Zenoh session opens with the first ``Node``, configured as
rmw_zenoh_cpp configures a ROS 2 process (``ZENOH_SESSION_CONFIG_URI``,
``ZENOH_CONFIG_OVERRIDE``, ``ZENOH_ROUTER_CHECK_ATTEMPTS``), with a
shared-memory pool as in Rust (``ZENOH_SHM_ALLOC_SIZE``,
``ZENOH_SHM_MESSAGE_SIZE_THRESHOLD``).
"""

from dataclasses import dataclass
from enum import IntEnum

from . import _native
from ._native import (
    Client,
    Clock,
    Loan,
    LoanMemory,
    Logger,
    Message,
    MessageType,
    Parameter,
    Publisher,
    SampleMemory,
    Service,
    ServiceType,
    SessionClosedError,
    SetParametersResult,
    ShmCdrError,
    Subscription,
    Time,
    Timer,
    message_type,
    ok,
    service_type,
    shutdown,
)

__all__ = [
    "Client",
    "Clock",
    "DurabilityPolicy",
    "HistoryPolicy",
    "Loan",
    "LoanMemory",
    "Logger",
    "LoggingSeverity",
    "Message",
    "MessageType",
    "Node",
    "Parameter",
    "Publisher",
    "QoSProfile",
    "ReliabilityPolicy",
    "SampleMemory",
    "Service",
    "ServiceType",
    "SessionClosedError",
    "SetParametersResult",
    "ShmCdrError",
    "Subscription",
    "Time",
    "Timer",
    "init",
    "message_type",
    "ok",
    "service_type",
    "shutdown",
    "spin",
]


class HistoryPolicy(IntEnum):
    """rmw's history policies, numbered as rclpy numbers them."""

    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2


class ReliabilityPolicy(IntEnum):
    """rmw's reliability policies, numbered as rclpy numbers them."""

    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2


class DurabilityPolicy(IntEnum):
    """rmw's durability policies, numbered as rclpy numbers them."""

    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2


@dataclass
class QoSProfile:
    """A QoS profile with rclpy's attributes; rclpy's own ``QoSProfile`` is
    taken too, and so is a plain depth (keep last, reliable, volatile)."""

    depth: int = 10
    history: HistoryPolicy = HistoryPolicy.KEEP_LAST
    reliability: ReliabilityPolicy = ReliabilityPolicy.RELIABLE
    durability: DurabilityPolicy = DurabilityPolicy.VOLATILE


class LoggingSeverity(IntEnum):
    """Logger levels, numbered as rclpy's ``LoggingSeverity``."""

    UNSET = 0
    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


class Node:
    """A ROS 2 node, as rclpy's ``Node``: ``Node("talker", namespace="/robot",
    cli_args=sys.argv)``, or a subclass of it (``super().__init__("talker")``).

    The arguments after ``--ros-args`` remap names (``-r chatter:=talk``,
    ``-r __ns:=/robot``) and set parameters (``-p``, ``--params-file``).
    """

    def __init__(self, node_name, *, namespace=None, cli_args=None, args=None):
        own = cli_args if cli_args is not None else args
        if _init_args is not None:
            # The process's arguments first, the node's own after (and winning).
            own = _init_args + list(own or [])
        self._node = _native.Node(node_name, namespace, args=own)

    def get_name(self):
        """The node's name."""
        return self._node.get_name()

    def get_namespace(self):
        """The node's namespace (``/`` for the root)."""
        return self._node.get_namespace()

    def get_fully_qualified_name(self):
        """``/namespace/name``."""
        return self._node.get_fully_qualified_name()

    def create_timer(self, timer_period_sec, callback):
        """Call ``callback()`` every ``timer_period_sec`` seconds of the
        node's ROS time, on a thread of the timer's own; the node keeps the
        ``Timer`` until ``destroy_timer``. Run ``shm_cdr.spin()`` to see the
        exceptions it raises."""
        return self._node.create_timer(timer_period_sec, callback)

    def destroy_timer(self, timer):
        """Stop ``timer``; whether the node had it."""
        return self._node.destroy_timer(timer)

    def get_clock(self):
        """The node's ``Clock``: ``get_clock().now().to_msg()`` is a stamp."""
        return self._node.get_clock()

    def get_logger(self):
        """The node's ``Logger`` (``robot.talker`` for ``/robot/talker``), as
        rclpy's: ``info``, ``warning``, ``error``, … print to stderr and
        publish on ``/rosout``."""
        return self._node.get_logger()

    def create_publisher(self, msg_type, topic, qos_profile=10):
        """A publisher of ``msg_type`` (a ``MessageType`` or its name) on
        ``topic``; ``qos_profile`` is a depth or a QoS profile."""
        return self._node.create_publisher(msg_type, topic, qos_profile)

    def create_subscription(self, msg_type, topic, callback=None, qos_profile=10):
        """A subscription to ``msg_type`` on ``topic``. With a ``callback``,
        each message goes to it on a thread of the node's executor (run
        ``shm_cdr.spin()`` to see the exceptions it raises); without, the
        subscription is an iterator of messages (or ``recv(timeout)``). The
        node keeps a callback's subscription, as rclpy's does, until
        ``destroy_subscription``."""
        return self._node.create_subscription(msg_type, topic, callback, qos_profile)

    def create_client(self, srv_type, srv_name):
        """A client of the service ``srv_type`` (a ``ServiceType`` or its
        name) on ``srv_name``: ``client.call(request)``."""
        return self._node.create_client(srv_type, srv_name)

    def create_service(self, srv_type, srv_name, callback):
        """A server of the service ``srv_type`` (a ``ServiceType`` or its
        name) on ``srv_name``, as rclpy's: each call is answered by
        ``callback(request, response)``, which fills the ``response`` and
        returns it (or returns another message of the ``Response`` type, or a
        dict of its fields). It runs on a thread of the node's executor; an
        exception it raises is the client's error reply, and
        ``shm_cdr.spin()`` raises it."""
        return self._node.create_service(srv_type, srv_name, callback)

    def get_topic_type(self, topic, timeout_sec=5.0, interfaces=None):
        """The ``MessageType`` of ``topic`` as its publishers (else
        subscribers) announce it: the standard type of that hash, else the
        ``.msg`` files of ``interfaces``, else the description the announcing
        node gives through its type-description service. Waits up to
        ``timeout_sec`` for the topic and the node's answer."""
        return self._node.get_topic_type(topic, timeout_sec, interfaces)

    def get_service_type(self, srv_name, timeout_sec=5.0):
        """The ``ServiceType`` of ``srv_name`` as its servers announce it:
        the standard type of that hash, else the description the server's
        node gives. Waits up to ``timeout_sec`` for a server and the answer."""
        return self._node.get_service_type(srv_name, timeout_sec)

    def declare_parameter(self, name, value=None):
        """Declare parameter ``name`` with its default ``value`` (the value
        ``--ros-args -p name:=...`` gave wins); returns the ``Parameter``."""
        return self._node.declare_parameter(name, value)

    def get_parameter(self, name):
        """The declared parameter ``name`` (``LookupError`` if it is not)."""
        return self._node.get_parameter(name)

    def has_parameter(self, name):
        """Whether parameter ``name`` is declared."""
        return self._node.has_parameter(name)

    def set_parameters(self, parameters):
        """Set parameters, all or none: a list of ``Parameter`` or a dict of
        names to values. One ``SetParametersResult`` per parameter."""
        return self._node.set_parameters(parameters)

    def destroy_subscription(self, subscription):
        """Let the node forget ``subscription``; whether it had it."""
        return self._node.destroy_subscription(subscription)

    def destroy_service(self, service):
        """Let the node forget ``service``; whether it had it."""
        return self._node.destroy_service(service)

    def destroy_node(self):
        """Stop the node's timers and let it forget its subscriptions and
        services, as rclpy's ``destroy_node``: each ends when Python frees
        it."""
        self._node.destroy_node()

    def __repr__(self):
        return f"shm_cdr.Node({self.get_fully_qualified_name()!r})"


_init_args = None


def init(args=None):
    """As ``rclpy.init(args=args)``: the ROS arguments of ``args``
    (``sys.argv`` if ``None``; those after ``--ros-args``: remaps,
    parameters, log levels) apply to every node made after, before each
    node's own ``cli_args``. Nodes work without it; called again, it
    replaces the arguments."""
    import sys

    global _init_args
    _init_args = list(sys.argv if args is None else args)


def spin(node=None, timeout_sec=None):
    """Wait for callbacks, as ``rclpy.spin(node)``: until ``timeout_sec``
    seconds pass (for ever if ``None``), a callback raises (its exception is
    raised here) or Ctrl-C. Callbacks run on the executor's threads whether
    or not anything spins; ``node`` is taken for rclpy's signature."""
    _native.spin(timeout_sec)
