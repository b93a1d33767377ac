"""Entries for what Django, django-axes and the fleet announce by signal or hook (connected in
hospital_delivery/extensions.py): sign-ins, failed sign-ins, sign-outs, lock-outs, robot tokens.
"""

from django.contrib import messages
from django.contrib.auth import get_user_model
from django.utils import timezone

from audit.choices import Kind
from audit.selectors import sign_ins_of
from audit.services import entry_record


def on_logged_in(sender, request, user, **kwargs) -> None:
    """django.contrib.auth's user_logged_in: with the backend that checked the password. The
    person is told when they last signed in and how often someone failed with their name since,
    so that a sign-in that was not theirs shows."""
    if request is not None and hasattr(request, "_messages"):
        messages.info(request, sign_ins_words(sign_ins_of(user)))
    backend = getattr(user, "backend", "") or ""
    entry_record(kind=Kind.SIGN_IN, obj=user, actor=user, data={"backend": backend})


def sign_ins_words(seen) -> str:
    """The previous sign-in in words, for the person (after signing in) and the admin."""
    if seen.last_at is None:
        words = "No earlier sign-in is recorded."
    else:
        at = timezone.localtime(seen.last_at).strftime("%Y-%m-%d %H:%M")
        words = f"Last signed in on {at} from {seen.last_address or 'an unknown address'}."
    if seen.failures_since:
        words += f" Failed sign-ins with this user name since: {seen.failures_since}."
    return words


def on_login_failed(sender, credentials=None, request=None, **kwargs) -> None:
    """django.contrib.auth's user_login_failed: the user name tried (known or not), never the
    password; the actor is nobody, since nobody proved who they are."""
    name = str((credentials or {}).get(get_user_model().USERNAME_FIELD, ""))[:150]
    entry_record(
        kind=Kind.SIGN_IN_FAILED,
        model=get_user_model(),
        object_repr=name,
        data={"username": name},
    )


def on_logged_out(sender, request, user, **kwargs) -> None:
    """django.contrib.auth's user_logged_out: `user` is the request's (lazy) user."""
    if user is not None and user.is_authenticated:
        user = getattr(user, "_wrapped", user)  # the user itself, read by is_authenticated
        entry_record(kind=Kind.SIGN_OUT, obj=user, actor=user)


def on_locked_out(sender, request=None, username=None, ip_address=None, **kwargs) -> None:
    """django-axes' user_locked_out: too many failures for this user name from this address."""
    name = str(username or "")[:150]
    entry_record(
        kind=Kind.LOCKED_OUT,
        model=get_user_model(),
        object_repr=name,
        data={"username": name},
    )


def on_token_issued(*, robot) -> None:
    """robots.hooks.token_issued: a robot's new token (its old one stops working)."""
    entry_record(
        kind=Kind.TOKEN_ISSUED,
        obj=robot,
        changes={"token_issued_at": [None, robot.token_issued_at.isoformat()]},
    )
