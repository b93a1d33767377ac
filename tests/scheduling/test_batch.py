"""A burst of due tasks is allocated in one batch under the site's lock (real PostgreSQL)."""

from django.db import connection
from django.test.utils import CaptureQueriesContext

from core import changes
from scheduling import tasks as celery_tasks
from scheduling.models import Task, TaskTransition
from scheduling.services import allocation, site_allocate_due, task_allocate_with_its_site
from tests.scheduling.conftest import pending_plans, request


def test_it_allocates_a_burst_in_one_batch_with_one_plan_per_robot(r1, r2, site):
    tasks = [request(site, receiver=f"Nurse {n}") for n in range(5)]
    stat = request(site, priority="stat", dropoffs=("3F-WARD",))

    assert site_allocate_due(site_id=site.pk) == 6

    assert set(Task.objects.values_list("status", flat=True)) == {"assigned"}
    plans = {robot.code: pending_plans(robot) for robot in (r1, r2)}
    assert all(len(posted) == 1 for posted in plans.values())  # one plan each, not one per task
    planned = [stop["task"] for posted in plans.values() for stop in posted[0].body["stops"]]
    assert sorted(set(planned)) == sorted(task.code for task in [*tasks, stat])
    first = TaskTransition.objects.filter(cause="allocation").order_by("id").first()
    assert first.task_id == stat.pk  # STAT first


def test_a_batch_records_its_allocations_in_one_insert_each_told(r1, r2, site):
    tasks = [request(site, receiver=f"Nurse {n}") for n in range(4)]
    told = []

    def watch(kind, subject, **_):
        if kind == changes.TASK:
            told.append(subject)

    with changes.changed.watched_by(watch), CaptureQueriesContext(connection) as queries:
        assert site_allocate_due(site_id=site.pk) == 4

    inserts = [
        q
        for q in queries.captured_queries
        if q["sql"].startswith('INSERT INTO "scheduling_tasktransition"')
    ]
    assert len(inserts) == 1
    entries = TaskTransition.objects.filter(cause="allocation")
    assert sorted((e.task_id, e.old, e.new, e.robot_id) for e in entries) == sorted(
        (t.pk, "due", "assigned", Task.objects.get(pk=t.pk).robot_id) for t in tasks
    )
    assert sorted(entry.pk for entry in told) == sorted(e.pk for e in entries)


def test_the_workers_message_allocates_its_task_with_the_rest_of_its_site(r1, site):
    first, second = request(site), request(site, receiver="Dr Lee")

    assert task_allocate_with_its_site(task_id=second.pk) == 2
    assert task_allocate_with_its_site(task_id=first.pk) == 0  # nothing left: a no-op

    assert {task.robot_id for task in Task.objects.all()} == {r1.pk}
    assert len(pending_plans(r1)) == 1


def test_a_batch_wakes_its_robots_only_when_it_commits(
    r1, r2, site, monkeypatch, django_capture_on_commit_callbacks
):
    woken = []
    monkeypatch.setattr("boards.push.group_send", lambda group, message: woken.append(group))
    [request(site, receiver=f"Nurse {n}") for n in range(3)]

    with django_capture_on_commit_callbacks(execute=False) as callbacks:
        assert site_allocate_due(site_id=site.pk) == 3
    assert woken == []  # a woken heartbeat would wait for the rest of the batch on its row

    for callback in callbacks:
        callback()
    assert sorted(set(woken)) == sorted(f"robot-{r.code}" for r in (r1, r2) if pending_plans(r))
    assert woken


def test_a_robot_paused_while_the_batch_chose_is_passed_over_and_nothing_is_lost(
    r1, r2, site, monkeypatch
):
    tasks = [request(site, receiver=f"Nurse {n}") for n in range(4)]
    lock_if_available = allocation.robot_lock_if_available
    chosen = []

    def paused_meanwhile(robot_id, site):  # R1 was paused by an operator after it was read
        chosen.append(robot_id)
        return None if robot_id == r1.pk else lock_if_available(robot_id, site)

    monkeypatch.setattr(allocation, "robot_lock_if_available", paused_meanwhile)

    assert site_allocate_due(site_id=site.pk) == 4

    assert {t.robot_id for t in Task.objects.filter(pk__in=[t.pk for t in tasks])} == {r2.pk}
    assert pending_plans(r1) == []
    assert len(pending_plans(r2)) == 1
    assert TaskTransition.objects.filter(cause="allocation").count() == 4  # none doubled
    assert chosen.count(r1.pk) == 2  # chosen unlocked, then again when the batch was made again


def test_a_robot_whose_route_changed_meanwhile_plans_its_new_tasks_on_it(r1, site, monkeypatch):
    held = request(site)
    assert site_allocate_due(site_id=site.pk) == 1
    new = [request(site, receiver="Dr Lee"), request(site, receiver="Dr Kim")]
    lock_if_available = allocation.robot_lock_if_available
    locked = []

    def acked_meanwhile(robot_id, site):  # R1 acked its plan after the batch read its route
        Task.objects.filter(pk=held.pk).update(status="acknowledged")
        locked.append(robot_id)
        return lock_if_available(robot_id, site)

    monkeypatch.setattr(allocation, "robot_lock_if_available", acked_meanwhile)

    assert site_allocate_due(site_id=site.pk) == 2

    assert locked == [r1.pk]  # locked once: the batch was not made again
    [plan] = pending_plans(r1)
    planned = {stop["task"] for stop in plan.body["stops"]}
    assert planned == {task.code for task in [held, *new]}
    assert Task.objects.get(pk=held.pk).status == "acknowledged"


def test_a_batch_plans_each_stop_once_and_is_made_once(r1, site, monkeypatch):
    tasks = [request(site, receiver=f"Nurse {n}") for n in range(3)]
    made = []
    add = allocation._Batch.add
    monkeypatch.setattr(
        allocation._Batch, "add", lambda self, task: made.append(task) or add(self, task)
    )

    assert site_allocate_due(site_id=site.pk) == 3

    assert len(made) == 3  # not made again: its own tasks are no change of the robot's route
    [plan] = pending_plans(r1)
    stops = [(stop["task"], stop["action"]) for stop in plan.body["stops"]]
    assert sorted(stops) == sorted((t.code, a) for t in tasks for a in ("pickup", "dropoff"))


def test_a_site_has_one_allocation_message_on_its_way_until_the_worker_takes_it(
    r1, site, monkeypatch, django_capture_on_commit_callbacks
):
    sent = []
    monkeypatch.setattr(
        celery_tasks.allocate_task,
        "delay",
        lambda task_id, pending: sent.append((task_id, pending)),
    )
    with django_capture_on_commit_callbacks(execute=True):
        first, second = request(site), request(site, receiver="Dr Lee")
    assert [task for task, _ in sent] == [first.pk]  # the second's is the first's message

    celery_tasks.allocate_task(*sent[0])  # the worker takes it: a batch of both

    assert {Task.objects.get(pk=t.pk).status for t in (first, second)} == {"assigned"}
    with django_capture_on_commit_callbacks(execute=True):
        third = request(site, receiver="Dr Kim")
    assert [task for task, _ in sent] == [first.pk, third.pk]  # the site's key was freed


def test_a_task_cancelled_while_the_batch_chose_is_left_out_and_the_rest_assigned(
    r1, r2, site, monkeypatch
):
    tasks = [request(site, receiver=f"Nurse {n}") for n in range(3)]
    choose = allocation._choose

    def cancelling_the_second(new, task, routes, travel_time):
        if task.pk == tasks[1].pk:  # a nurse cancels it between the batch's read and its claim
            Task.objects.filter(pk=task.pk).update(status="cancelled")
        return choose(new, task, routes, travel_time)

    monkeypatch.setattr(allocation, "_choose", cancelling_the_second)

    assert site_allocate_due(site_id=site.pk) == 2

    cancelled = Task.objects.get(pk=tasks[1].pk)
    assert (cancelled.status, cancelled.robot_id, cancelled.assigned_at) == (
        "cancelled",
        None,
        None,
    )
    planned = {stop["task"] for r in (r1, r2) for p in pending_plans(r) for stop in p.body["stops"]}
    assert planned == {tasks[0].code, tasks[2].code}
    assert not TaskTransition.objects.filter(task_id=tasks[1].pk, cause="allocation").exists()
