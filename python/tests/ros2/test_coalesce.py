"""The bridge's command queue: latest wins, an estop wins over everything before it, bounded."""

from __future__ import annotations

from nurimc.ros2.coalesce import CommandQueue


def drain(queue: CommandQueue) -> list[tuple[str, object]]:
    events = []
    while (event := queue.pop()) is not None:
        events.append(event)
    return events


def test_the_latest_motion_command_replaces_the_queued_one() -> None:
    q = CommandQueue()
    for i in range(10_000):
        q.push("position" if i % 2 else "velocity", [float(i)])
    assert len(q) == 1 and q.dropped == 9_999
    assert drain(q) == [("position", [9999.0])]


def test_keyed_work_coalesces_per_key_and_keeps_the_order_of_the_rest() -> None:
    q = CommandQueue()
    q.push("call", "left 1", "control:a")
    q.push("call", "base 1", "cmd_vel")
    q.push("call", "once", None)
    q.push("call", "left 2", "control:a")
    q.push("velocity", [1.0])
    q.push("call", "base 2", "cmd_vel")
    q.push("call", "twice", None)
    assert drain(q) == [
        ("call", "once"),
        ("call", "left 2"),
        ("velocity", [1.0]),
        ("call", "base 2"),
        ("call", "twice"),
    ]
    assert q.dropped == 2


def test_an_estop_drops_what_came_before_it_but_not_after() -> None:
    q = CommandQueue()
    q.push("velocity", [1.0])
    q.push("call", "x", "cmd_vel")
    q.push("estop", True)
    q.push("position", [2.0])
    q.push("estop", False)
    assert q.has_estop()
    assert drain(q) == [("estop", True), ("estop", False)]
    assert not q.has_estop() and q.dropped == 3


def test_a_flood_of_every_kind_stays_bounded() -> None:
    q = CommandQueue()
    for i in range(5_000):
        q.push("velocity", [float(i)])
        q.push("call", i, f"control:{i % 3}")
        q.push("call", i, "cmd_vel")
    assert len(q) == 5  # one motion command, three joint sets, one cmd_vel
