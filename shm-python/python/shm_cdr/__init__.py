"""ROS 2 messages through Zenoh shared memory, on rmw_zenoh_cpp's wire.

Nodes, publishers and subscriptions of any ROS 2 interface: the standard set
built in, your own ``.msg`` files (``message_type(name, interfaces=[...])``).
A received message's arrays of numbers are numpy arrays that view the sample
where it arrived (in shared memory when it came through it), read-only.

The process's Zenoh session opens with the first ``Node``, configured as
rmw_zenoh_cpp configures a ROS 2 process (``ZENOH_SESSION_CONFIG_URI``,
``ZENOH_CONFIG_OVERRIDE``, ``ZENOH_ROUTER_CHECK_ATTEMPTS``), with a
shared-memory pool as in Rust (``ZENOH_SHM_ALLOC_SIZE``,
``ZENOH_SHM_MESSAGE_SIZE_THRESHOLD``).
"""

from dataclasses import dataclass
from enum import IntEnum

from ._native import (
    Message,
    MessageType,
    Node,
    Parameter,
    Publisher,
    SampleMemory,
    SessionClosedError,
    SetParametersResult,
    ShmCdrError,
    Subscription,
    message_type,
    ok,
    shutdown,
    spin,
)

__all__ = [
    "DurabilityPolicy",
    "HistoryPolicy",
    "Message",
    "MessageType",
    "Node",
    "Parameter",
    "Publisher",
    "QoSProfile",
    "ReliabilityPolicy",
    "SampleMemory",
    "SessionClosedError",
    "SetParametersResult",
    "ShmCdrError",
    "Subscription",
    "message_type",
    "ok",
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
