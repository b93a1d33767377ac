from scheduling.models.custody import CustodyEntry, CustodyKind
from scheduling.models.operator import OperatorAction
from scheduling.models.plans import AllocationLock, RobotPlan
from scheduling.models.recurring import RecurringRequest
from scheduling.models.tasks import Task, TaskStop, TaskTransition, task_code, task_pk

__all__ = [
    "AllocationLock",
    "CustodyEntry",
    "CustodyKind",
    "OperatorAction",
    "RecurringRequest",
    "RobotPlan",
    "Task",
    "TaskStop",
    "TaskTransition",
    "task_code",
    "task_pk",
]
