"""Where lower layers hand work up: every receiver of every extension point, in the order each
runs. Nothing else connects them (core/hooks.py).

The layers (pyproject.toml, [tool.importlinter]) point down: the fleet (robots) knows nothing of
the message board (boards), the board nothing of the resource controller (resources) or the
scheduler (scheduling), and none of them anything of the pages (ui). Where a lower layer must
reach up, it calls a hook, and the project package, which sits above all of them, says here who
answers.
"""

from axes.signals import user_locked_out
from celery.signals import task_success
from django.contrib.auth import get_user_model
from django.contrib.auth.signals import user_logged_in, user_logged_out, user_login_failed
from django.db.backends.signals import connection_created
from django.db.models.signals import m2m_changed, post_delete, post_save

from accounts import languages
from audit import receivers as audit
from boards import push
from boards.hooks import heartbeat_applied
from building import receivers as building
from building.hooks import fire_panel_changed
from core import watchdog
from core.changes import changed
from hospital_delivery import activity, privatefiles, sessions, signin
from resources import receivers as resources
from resources.hooks import availability_changed, lease_changed
from robots.hooks import presence_changed, token_issued
from robots.models import SiteMembership
from scheduling import receivers as scheduling
from scheduling.hooks import fire_alarm_changed
from ui.live import publish
from webhooks import receivers as webhooks


def connect() -> None:
    # A heartbeat's resource events and requests first, then its task events: a robot that
    # reports resource_released and task_completed in one heartbeat frees the lift before the
    # scheduler plans its next move. Either may refuse the heartbeat (400, nothing applied).
    heartbeat_applied.connect(resources.on_heartbeat_applied, scheduling.on_heartbeat_applied)
    # A robot gone offline leaves the lease queues it waits in, then gives back its tasks.
    presence_changed.connect(resources.on_presence_changed, scheduling.on_presence_changed)
    # A lease that changes drives its resource's lift or door: called to the robot's floor on
    # a grant, sent to its destination once it is inside, doors closed after it has left.
    lease_changed.connect(building.on_lease_changed)
    # The building's fire panel starts or ends the site's fire alarm.
    fire_panel_changed.connect(scheduling.on_fire_panel_changed)
    # A fire alarm stops the lift cars with a robot inside at their next floor and lets the
    # robots out; at the all-clear a robot still inside rides on to its destination.
    fire_alarm_changed.connect(building.on_fire_alarm_changed)
    # A resource out of or back in service: routes are planned again (after commit).
    availability_changed.connect(scheduling.on_availability_changed)
    # A robot's new token closes the push sockets opened with its old one, and is audited.
    token_issued.connect(push.robot_sockets_close, audit.on_token_issued)
    # Whatever changed that people can see goes to the site's live pages after commit.
    # Then, for other hospital systems, a task's status change becomes a webhook delivery
    # stored in the same transaction (sent after commit, retried until answered). Last, a line
    # in the activity log for a delivery's status change or an alert (after commit).
    changed.connect(publish.on_change, webhooks.on_change, activity.on_change)
    # A new session counts as used just now (its idle time, hospital_delivery/sessions.py).
    user_logged_in.connect(sessions.on_logged_in, dispatch_uid="session-idle-login")
    # The person's own language, if they chose one, for the new session's pages.
    user_logged_in.connect(languages.on_logged_in, dispatch_uid="account-language-login")
    # Every failed sign-in counts against its client address (the sign-in throttle).
    user_login_failed.connect(signin.on_login_failed, dispatch_uid="signin-throttle")
    # Logging out closes that session's live pages (Django's own signal).
    user_logged_out.connect(publish.on_user_logged_out, dispatch_uid="ui-live-logout")
    # A user deactivated, deleted, moved between groups or sites: their live pages check their
    # access again and close if it is gone (Django's model signals).
    user = get_user_model()
    for name, signal in (("saved", post_save), ("deleted", post_delete)):
        signal.connect(publish.on_user_saved, sender=user, dispatch_uid=f"ui-live-user-{name}")
        signal.connect(
            publish.on_membership_changed,
            sender=SiteMembership,
            dispatch_uid=f"ui-live-membership-{name}",
        )
    m2m_changed.connect(
        publish.on_user_groups_changed, sender=user.groups.through, dispatch_uid="ui-live-groups"
    )
    # Sign-ins, failed sign-ins (whatever the user name), sign-outs and lock-outs go into the
    # audit trail (audit/receivers.py; model changes come through django-auditlog's own).
    user_logged_in.connect(audit.on_logged_in, dispatch_uid="audit-login")
    user_login_failed.connect(audit.on_login_failed, dispatch_uid="audit-login-failed")
    user_logged_out.connect(audit.on_logged_out, dispatch_uid="audit-logout")
    user_locked_out.connect(audit.on_locked_out, dispatch_uid="audit-locked-out")
    # Each sweep that finishes records when (the sweeps' watchdog, which /healthz, every page and
    # the metrics read; Celery's own signal).
    task_success.connect(watchdog.sweep_ran, weak=False, dispatch_uid="sweeps-watchdog")
    # A new SQLite connection makes the database file readable by its owner only.
    connection_created.connect(privatefiles.sqlite_private, dispatch_uid="sqlite-private")
