"""The scheduler's receivers of lower layers' hooks (connected, in order, in
hospital_delivery/extensions.py)."""

from robots.choices import Presence
from scheduling import services
from scheduling.services.charging import robot_battery_check
from scheduling.services.emergency import emergency_heartbeat_check, emergency_panel_apply
from scheduling.services.etas import heartbeat_progress
from scheduling.services.plans import plan_restore


def on_heartbeat_applied(*, applied) -> None:
    services.heartbeat_tasks_apply(applied=applied)
    # After its events: what a faulty robot reports loaded in the same heartbeat stays with it.
    services.heartbeat_fault_check(applied=applied)
    heartbeat_progress(applied=applied)  # learn the robot's pace, recompute its ETAs
    if applied.new_boot:  # a restarted robot that lost its acked plan gets one again
        plan_restore(robot=applied.robot, now=applied.now)
    if applied.state_applied:
        robot_battery_check(robot=applied.robot, now=applied.now)
    emergency_heartbeat_check(applied=applied)  # out of a lift onto a floor in a fire alarm


def on_presence_changed(*, robot, old, new, at) -> None:
    if new == Presence.OFFLINE:
        services.robot_offline(robot=robot, at=at)


def on_availability_changed(*, resource, now) -> None:
    """A resource went out of or back into service: routes are planned again after commit."""
    services.reroute_enqueue(site_id=resource.site_id, resource=resource.code)


def on_fire_panel_changed(*, site, alarm, floors, reason) -> None:
    emergency_panel_apply(site=site, alarm=alarm, floors=floors, reason=reason)
