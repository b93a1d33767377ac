"""Live page events: what services report as changed (core/changes.py) goes to the pages
watching the site, as {"kind", "data"} on their websocket (ui/live/consumers.py), once the
transaction that made the change commits.

Three groups: every page of a site ("site-<id>"); the pages of one login session
("session-<hash>"), which close when it logs out; and the pages of one user ("user-<id>"),
which check their access again when the user is changed (deactivated, moved between groups,
added to or removed from a site), and close if it is gone.
"""

import hashlib
import logging

from django.conf import settings
from django.db import transaction
from django.utils import translation

from core import changes
from core.outbox import send_soon
from core.pubsub import group_send
from ui.live import payloads

logger = logging.getLogger(__name__)

PAYLOADS = {
    changes.ROBOT: payloads.robot_payload,
    changes.TASK: payloads.task_payload,
    changes.LEASE: payloads.lease_payload,
    changes.ALERT: payloads.alert_payload,
    changes.RESOURCE: payloads.resource_payload,
    changes.ALERT_ACKNOWLEDGED: payloads.alert_acknowledged_payload,
    changes.ETAS: payloads.etas_payload,
}


def site_group(site_id: int) -> str:
    return f"site-{site_id}"


def session_group(session_key: str) -> str:
    """The pages' sockets of one login session (the key itself stays out of Redis)."""
    return f"session-{hashlib.sha256(session_key.encode()).hexdigest()[:32]}"


def user_group(user_id: int) -> str:
    return f"user-{user_id}"


def on_change(*, kind: str, site_id: int, subject, **detail) -> None:
    """The receiver of core.changes.changed: the payload now (the subject as it is at this
    point of the transaction), sent after commit."""
    data, translated = payload_in_each_language(lambda: PAYLOADS[kind](subject, **detail))
    publish_on_commit(site_id=site_id, kind=kind, data=data, translated=translated)


def payload_in_each_language(build) -> tuple[dict, dict]:
    """The payload in the default language, and for each other language the fields that read
    differently in it (its labels), so one message serves every viewer: each page's socket
    lays its own language's fields over the data (ui/live/consumers.py)."""
    with translation.override(settings.LANGUAGE_CODE):
        data = build()
    translated = {}
    for language, _name in settings.LANGUAGES:
        if language == settings.LANGUAGE_CODE:
            continue
        with translation.override(language):
            other = build()
        changed = {key: value for key, value in other.items() if value != data.get(key)}
        if changed:
            translated[language] = changed
    return data, translated


def publish_on_commit(*, site_id: int, kind: str, data: dict, translated=None) -> None:
    """Tell the pages watching site_id that `kind` happened (e.g. "robot", "task", "lease")."""
    message = {"type": "site.event", "kind": kind, "data": data}
    if translated:
        message["translated"] = translated
    group = site_group(site_id)
    transaction.on_commit(lambda: send_soon(lambda: group_send(group, message), what=kind))


def on_user_logged_out(sender, request, user, **kwargs) -> None:
    """Close the pages' sockets of the session that has just logged out (after commit, if any;
    like every push, a failure is logged and the logout goes ahead)."""
    session_key = getattr(request, "session", None) and request.session.session_key
    if session_key:
        message = {"type": "session.ended"}
        group = session_group(session_key)
        send = lambda: group_send(group, message)  # noqa: E731
        transaction.on_commit(lambda: send_soon(send, what="closing a session's pages"))


def access_changed_on_commit(*, user_ids) -> None:
    """Ask the pages of these users to check their access again, after commit. Sent through
    Redis, so the pages' sockets hear it in whichever process serves them."""
    message = {"type": "access.changed"}
    for user_id in set(user_ids):
        group = user_group(user_id)
        send = lambda group=group: group_send(group, message)  # noqa: E731
        transaction.on_commit(lambda send=send: send_soon(send, what="checking pages' access"))


def on_user_saved(sender, instance, update_fields=None, created=False, **kwargs) -> None:
    """post_save and post_delete of a user: active, staff, deleted. A new user has no pages
    open, and a login saves last_login only, which changes no access."""
    if created or (update_fields is not None and set(update_fields) <= {"last_login"}):
        return
    access_changed_on_commit(user_ids=[instance.pk])


def on_user_groups_changed(sender, instance, action, reverse, pk_set, **kwargs) -> None:
    """m2m_changed of a user's groups, from either side (user.groups or group.user_set)."""
    if not reverse:
        if action.startswith("post_"):
            access_changed_on_commit(user_ids=[instance.pk])
    elif action == "pre_clear":  # group.user_set.clear(): its members, while they still are
        access_changed_on_commit(user_ids=list(instance.user_set.values_list("pk", flat=True)))
    elif action in ("post_add", "post_remove"):
        access_changed_on_commit(user_ids=pk_set)


def on_membership_changed(sender, instance, **kwargs) -> None:
    """post_save and post_delete of a SiteMembership."""
    access_changed_on_commit(user_ids=[instance.user_id])
