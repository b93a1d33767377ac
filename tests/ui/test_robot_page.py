"""A robot's page, and the operator's Pause, Resume and Return to dock (protocol `action`)."""

import pytest

from boards.models import BoardMessage
from robots.models import Robot
from robots.selectors import robots_for_allocation
from scheduling.models import OperatorAction, Task
from scheduling.services import robot_action, task_allocate
from tests import factories
from tests.scheduling.conftest import Beater, event, plans, request, robot_ready


@pytest.fixture
def r1(site):
    return robot_ready(factories.robot_create(site, "R1"))


def actions_on_board(robot) -> list[str]:
    pending = BoardMessage.objects.pending().filter(robot=robot, type="action").order_by("id")
    return [message.body["action"] for message in pending]


def test_it_shows_state_plan_events_and_presence(nurse_client, site):
    beater = Beater(factories.robot_create(site, "R1"))
    beater.beat(status="idle", battery=0.5, load=0)  # online; a presence change
    task = request(site)
    task_allocate(task_id=task.pk)
    beater.beat(status="moving", battery=0.5, events=[event("task_received", task.code)])

    html = nurse_client.get("/robots/R1/").content.decode()

    assert "Robot R1" in html
    assert "Moving" in html
    assert "50 %" in html
    assert "Current plan" in html
    assert f'href="/deliveries/{task.code}/"' in html
    assert "Pharmacy" in html
    assert "Laboratory" in html
    assert "Task received" in html  # recent events
    assert "Offline → <strong>Online</strong>" in html  # presence history


def test_it_lets_an_operator_pause_a_robot(operator_client, operator, r1):
    response = operator_client.post("/robots/R1/action", {"action": "pause"}, follow=True)

    assert "Pause sent to R1." in response.content.decode()
    assert actions_on_board(r1) == ["pause"]
    r1.refresh_from_db()
    assert r1.paused_by_operator
    recorded = OperatorAction.objects.get()
    assert (recorded.action, recorded.by, recorded.robot) == ("pause", operator, r1)
    assert "Pause</strong> by park" in response.content.decode()


def test_it_sends_the_action_in_the_robots_next_heartbeat(operator_client, r1):
    operator_client.post("/robots/R1/action", {"action": "pause"})

    reply = Beater(r1).beat()

    assert {"type": "action", "action": "pause"} in [
        {key: message[key] for key in ("type", "action")}
        for message in reply["messages"]
        if message["type"] == "action"
    ]


def test_it_forbids_nurses_to_command_robots(nurse_client, r1):
    for action in ("pause", "resume", "return_to_dock"):
        assert nurse_client.post("/robots/R1/action", {"action": action}).status_code == 403

    assert actions_on_board(r1) == []
    assert not OperatorAction.objects.exists()


def test_it_hides_the_operator_buttons_from_nurses(nurse_client, operator_client, r1):
    assert b">Pause</button>" not in nurse_client.get("/robots/R1/").content
    html = operator_client.get("/robots/R1/").content.decode()
    for label in ("Pause", "Return to dock"):
        assert f">{label}</button>" in html


def test_it_offers_only_the_buttons_that_make_sense_for_the_robots_state(
    operator_client, operator, r1
):
    def buttons() -> set[str]:
        html = operator_client.get("/robots/R1/").content.decode()
        labels = ("Pause", "Resume", "Return to dock")
        return {label for label in labels if f">{label}</button>" in html}

    assert buttons() == {"Pause", "Return to dock"}
    robot_action(robot=r1, action="pause", by=operator)
    assert buttons() == {"Resume", "Return to dock"}
    robot_action(robot=r1, action="resume", by=operator)
    Beater(r1).beat(status="error", errors=["lidar"])  # held after a fault
    assert buttons() == {"Pause", "Resume", "Return to dock"}
    html = operator_client.get("/robots/R1/").content.decode()
    assert "held after a fault" in html
    assert 'data-confirm="Send R1 back to its dock?' in html


def test_it_refuses_unknown_actions(operator_client, r1):
    assert operator_client.post("/robots/R1/action", {"action": "dance"}).status_code == 400
    assert actions_on_board(r1) == []


def test_it_keeps_a_paused_robot_out_of_allocation_until_resumed(operator, site, r1):
    robot_action(robot=r1, action="pause", by=operator)
    task = request(site)

    assert robots_for_allocation(site=site) == []
    assert not task_allocate(task_id=task.pk)

    robot_action(robot=r1, action="resume", by=operator)

    assert task_allocate(task_id=task.pk)
    assert Task.objects.get(pk=task.pk).robot_id == r1.pk


def test_it_replaces_an_action_the_robot_has_not_received_yet(operator, r1):
    robot_action(robot=r1, action="pause", by=operator)
    robot_action(robot=r1, action="resume", by=operator)

    assert actions_on_board(r1) == ["resume"]
    assert not Robot.objects.get(pk=r1.pk).paused_by_operator


def test_it_sends_a_robot_to_its_dock_giving_back_what_it_has_not_picked_up(operator, site, r1):
    beater = Beater(r1)
    waiting, loaded = request(site), request(site, pickups=["3F-WARD"], dropoffs=["1F-PHARM"])
    task_allocate(task_id=waiting.pk)
    task_allocate(task_id=loaded.pk)
    beater.ack_all(beater.beat(), events=[event("loaded", loaded.code, 0)])

    robot_action(robot=r1, action="return_to_dock", by=operator)

    waiting.refresh_from_db()
    loaded.refresh_from_db()
    assert (waiting.status, waiting.robot_id) == ("due", None)
    assert (waiting.history.last().user, waiting.history.last().cause) == (operator, "user")
    assert (loaded.status, loaded.robot_id) == ("picked_up", r1.pk)
    reply = beater.beat()
    types = [message["type"] for message in reply["messages"]]
    assert types[-2:] == ["plan", "action"]  # the corrected plan first, then the command
    assert reply["messages"][-1]["action"] == "return_to_dock"
    assert [stop["task"] for stop in plans(reply)[-1]["stops"]] == [loaded.code]
    assert robots_for_allocation(site=site) == []  # no new tasks until resumed
