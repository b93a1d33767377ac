from django.dispatch import Signal

# Sent inside the transaction that records a presence flip (robot row locked).
# Arguments: robot, old, new (robots.choices.Presence values), at (datetime).
presence_changed = Signal()
