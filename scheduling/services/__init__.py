"""Writes of the scheduler.

Lifecycle of a task (every change recorded as a TaskTransition with its cause):

    scheduled --time came--> due --allocation--> assigned (plan posted)
    assigned --plan acked / task_received / any event of its robot--> acknowledged
    acknowledged --all pick-ups loaded--> picked_up --all drop-offs unloaded--> delivered
    delivered --task_completed--> completed          (any held state --task_failed--> failed)
    assigned, acknowledged --task_failed (first time)--> due
    assigned --ack timeout--> due                    (assigned, acknowledged --offline--> due)
    assigned, acknowledged --robot fault--> due      (scheduling.services.faults)
    an event that does not fit the status (completed before the last drop-off, unloaded
    before loaded, loaded for a task not the robot's) --> no change, an anomaly alert
    scheduled, due, assigned, acknowledged --cancel--> cancelled
    picked_up (or partly loaded) --cancel--> picked_up with a return trip --unloaded--> cancelled

Lock order (no deadlocks): the site's AllocationLock row, taken only by allocation and first
(a request allocating the task it has just inserted takes it without waiting, or leaves the
task to the worker); then at most one robot row (robots.services.robot_lock) per transaction.
Everything but allocation takes only the robot's lock (heartbeats and presence changes already
hold it); when such code needs a task allocated again, it makes the task due and enqueues
allocation on commit, and the due sweep finds it anyway if that message is lost. Tasks with a
robot are changed only under that robot's lock; tasks without one only by conditional updates.
"""

from scheduling.services.allocation import (
    due_sweep,
    site_allocate_due,
    task_allocate,
    task_allocate_with_its_site,
)
from scheduling.services.cancellation import TaskChanged, TaskNotCancellable, task_cancel
from scheduling.services.emergency import EmergencyRefused, emergency_end, emergency_start
from scheduling.services.events import heartbeat_tasks_apply
from scheduling.services.faults import heartbeat_fault_check, robot_fault, robot_fault_resolve
from scheduling.services.maintenance import (
    MaintenanceRefused,
    maintenance_due_sweep,
    robot_maintenance_end,
    robot_maintenance_start,
)
from scheduling.services.operator import (
    resource_operator_record,
    resource_operator_set_priority,
    resource_operator_set_service,
    robot_action,
)
from scheduling.services.pins import PinNotResendable, task_pin_resend
from scheduling.services.presence import robot_offline, robot_tasks_give_back
from scheduling.services.recurring import recurring_stop
from scheduling.services.requests import recurring_sweep, task_request
from scheduling.services.rerouting import reroute_enqueue, site_reroute
from scheduling.services.timeouts import ack_timeout_sweep
from scheduling.services.unloading import task_move_on, unattended_sweep, unload_timeout_sweep

__all__ = [
    "PinNotResendable",
    "task_pin_resend",
    "EmergencyRefused",
    "MaintenanceRefused",
    "TaskChanged",
    "TaskNotCancellable",
    "ack_timeout_sweep",
    "due_sweep",
    "emergency_end",
    "emergency_start",
    "heartbeat_fault_check",
    "heartbeat_tasks_apply",
    "maintenance_due_sweep",
    "recurring_stop",
    "recurring_sweep",
    "reroute_enqueue",
    "resource_operator_record",
    "resource_operator_set_priority",
    "resource_operator_set_service",
    "robot_action",
    "robot_fault",
    "robot_fault_resolve",
    "robot_maintenance_end",
    "robot_maintenance_start",
    "robot_offline",
    "robot_tasks_give_back",
    "site_allocate_due",
    "site_reroute",
    "task_allocate",
    "task_allocate_with_its_site",
    "task_cancel",
    "task_move_on",
    "task_request",
    "unattended_sweep",
    "unload_timeout_sweep",
]
