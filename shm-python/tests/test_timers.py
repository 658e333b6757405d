"""Timers and clocks as rclpy's: callbacks every period on the node's ROS
time, kept by their node, stopped by cancel and destroy_timer, exceptions
raised by spin; the clock's now() as a message stamp."""

import time

import pytest

import shm_cdr


@pytest.fixture(scope="module")
def node():
    return shm_cdr.Node("ticker", namespace="/timers")


def test_a_timer_fires_every_period_until_canceled(node):
    ticks = []
    timer = node.create_timer(0.02, lambda: ticks.append(time.monotonic()))
    assert timer.timer_period_ns == 20_000_000
    deadline = time.monotonic() + 20.0
    while len(ticks) < 10 and time.monotonic() < deadline:
        shm_cdr.spin(timeout_sec=0.05)
    assert len(ticks) >= 10
    # Every period, not faster: ten ticks take at least nine periods.
    assert ticks[9] - ticks[0] >= 9 * 0.02 * 0.9
    timer.cancel()
    assert timer.is_canceled()
    time.sleep(0.05)  # a callback running at cancel() finishes
    fired = len(ticks)
    assert timer.fired == fired
    time.sleep(0.2)
    assert len(ticks) == fired


def test_the_node_keeps_a_timer_nobody_holds_until_destroyed(node):
    ticks = []
    node.create_timer(0.02, lambda: ticks.append(1))  # not kept by the caller
    deadline = time.monotonic() + 20.0
    while len(ticks) < 3 and time.monotonic() < deadline:
        time.sleep(0.02)
    assert len(ticks) >= 3
    timer = node.create_timer(0.02, lambda: None)
    assert node.destroy_timer(timer)
    assert timer.is_canceled()
    assert not node.destroy_timer(timer)


def test_a_timer_callback_that_raises_is_raised_by_spin_and_the_timer_goes_on(node):
    calls = []

    def tick():
        calls.append(1)
        if len(calls) == 2:
            raise RuntimeError("second tick")

    timer = node.create_timer(0.02, tick)
    try:
        with pytest.raises(RuntimeError, match="second tick"):
            shm_cdr.spin(timeout_sec=20.0)
        deadline = time.monotonic() + 20.0
        while len(calls) < 4 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert len(calls) >= 4
    finally:
        node.destroy_timer(timer)


def test_bad_periods_are_refused(node):
    with pytest.raises(ValueError, match="timer_period_sec"):
        node.create_timer(0.0, lambda: None)
    with pytest.raises(ValueError, match="timer_period_sec"):
        node.create_timer(-1.0, lambda: None)


def test_the_clock_gives_stamps(node):
    before = time.time_ns()
    now = node.get_clock().now()
    after = time.time_ns()
    assert before <= now.nanoseconds <= after
    sec, nanosec = now.seconds_nanoseconds()
    assert sec * 1_000_000_000 + nanosec == now.nanoseconds
    stamp = now.to_msg()
    assert stamp.type_name == "builtin_interfaces/msg/Time"
    assert (stamp.sec, stamp.nanosec) == (sec, nanosec)
    msg = shm_cdr.message_type("std_msgs/msg/Header")()
    msg.stamp = stamp
    assert msg.stamp.sec == sec
    assert node.get_clock().now() >= now
