"""The actor and client address of the work being done, for the entries it writes."""

import contextlib
from contextvars import ContextVar

from django.contrib.auth import get_user_model

from core.clientaddress import client_address

_acting: ContextVar[dict | None] = ContextVar("audit_acting", default=None)


@contextlib.contextmanager
def request_context(request):
    """The request's user (read only if an entry is written: the API authenticates inside the
    view, after this is set) and its client address."""
    token = _acting.set({"request": request})
    try:
        yield
    finally:
        _acting.reset(token)


@contextlib.contextmanager
def acting(*, actor=None, address: str | None = None):
    """Record what runs inside as done by `actor` from `address` (commands, tasks, tests)."""
    token = _acting.set({"actor": actor, "address": address})
    try:
        yield
    finally:
        _acting.reset(token)


def current_actor():
    """The signed-in user acting now, or None."""
    acting_now = _acting.get() or {}
    request = acting_now.get("request")
    actor = getattr(request, "user", None) if request is not None else acting_now.get("actor")
    if isinstance(actor, get_user_model()) and actor.is_authenticated:
        return actor
    return None


def current_address() -> str | None:
    acting_now = _acting.get() or {}
    request = acting_now.get("request")
    return client_address(request) if request is not None else acting_now.get("address")
