from django.dispatch import Signal

# Sent inside the transaction that records a presence flip (robot row locked).
# Arguments: robot, old, new (robots.choices.Presence values), at (datetime).
presence_changed = Signal()

# Sent inside the transaction of an operator's action on a robot (robots.operator.robot_action),
# robot row locked, before the action message is posted; so a receiver's board posts (a
# corrected plan) reach the robot before the action. Arguments: robot, action
# (robots.choices.OperatorActionKind value), by (the user), at (datetime).
operator_action = Signal()
