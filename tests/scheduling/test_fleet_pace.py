"""Robots are compared at the fleet's pace: one robot's learned pace (say twenty times the
map's estimate, in a sped-up simulation) must not make it look faster than robots that have
not travelled yet, or it is given every delivery and the others never learn theirs."""

from robots.models import Robot
from scheduling.services import task_allocate
from tests import factories
from tests.scheduling.conftest import request, robot_ready


def test_it_gives_the_delivery_to_the_nearer_robot_whatever_pace_one_has_learned(site):
    far = robot_ready(factories.robot_create(site, "R1"), at="3F-WARD")
    Robot.objects.filter(pk=far.pk).update(pace_travel=0.05)  # learned: 20x the map
    near = robot_ready(factories.robot_create(site, "R2"), at="1F-PHARM")
    task = request(site)  # Pharmacy to the laboratory

    assert task_allocate(task_id=task.pk)

    task.refresh_from_db()
    assert task.robot == near
