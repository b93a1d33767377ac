"""A robot that restarts and has lost the plan it acked gets a plan again (protocol document,
"What a robot keeps"); one that kept its plan is left alone."""

from tests.scheduling.conftest import plans
from tests.scheduling.test_faults import AT_DOCK, held_by


def acked_plan(robot_http, robot, site):
    robot_http.heartbeat(1, state=AT_DOCK)
    task = held_by(robot, site)
    [plan] = plans(robot_http.heartbeat(2, state=AT_DOCK))
    version = plan["plan_version"]
    robot_http.heartbeat(3, state={**AT_DOCK, "plan_version": version}, acks=[plan["id"]])
    assert plans(robot_http.heartbeat(4, state={**AT_DOCK, "plan_version": version})) == []
    return task, plan


def test_a_robot_that_restarts_without_its_plan_is_sent_it_again(robot_http, robot, site):
    task, plan = acked_plan(robot_http, robot, site)

    # New software start: a new boot_id, and the plan is gone (plan_version 0).
    reply = robot_http.heartbeat(1, boot_id="boot-2", state={**AT_DOCK, "plan_version": 0})

    [again] = plans(reply)
    assert again["plan_version"] > plan["plan_version"]
    assert list(again["tasks"]) == [task.code]
    assert [stop["task"] for stop in again["stops"]] == [task.code, task.code]


def test_a_robot_that_restarts_with_its_plan_is_not_sent_another(robot_http, robot, site):
    _, plan = acked_plan(robot_http, robot, site)

    kept = {**AT_DOCK, "plan_version": plan["plan_version"]}
    reply = robot_http.heartbeat(1, boot_id="boot-2", state=kept)

    assert plans(reply) == []


def test_a_late_heartbeat_of_an_earlier_boot_restores_nothing(robot_http, robot, site):
    _, plan = acked_plan(robot_http, robot, site)
    robot_http.heartbeat(1, boot_id="boot-2", state={**AT_DOCK, "plan_version": 0})

    # boot-1's late heartbeat is stale: its state (and any "restart") is not applied.
    late = robot_http.heartbeat(5, boot_id="boot-1", state={**AT_DOCK, "plan_version": 0})

    assert [m["plan_version"] for m in plans(late)] == [plan["plan_version"] + 1]  # still pending
