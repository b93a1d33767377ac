"""Who may use the pages: Django groups `nurse` and `operator` (created by a data migration).

Any user in either group, or a staff user, may use the pages and order deliveries; nurses may
cancel their own requests; operators (and staff) may cancel any task, pause, resume and return
robots and acknowledge alerts. Views enforce this on the server (the templates only hide what
a user may not do).
"""

from functools import wraps

from django.contrib.auth.decorators import login_required
from django.core.exceptions import PermissionDenied

NURSE = "nurse"
OPERATOR = "operator"
GROUPS = (NURSE, OPERATOR)


def roles_of(user) -> frozenset[str]:
    """The user's page groups, read once per request (cached on the user object)."""
    if not user.is_authenticated:
        return frozenset()
    roles = getattr(user, "_page_roles", None)
    if roles is None:
        names = user.groups.filter(name__in=GROUPS).values_list("name", flat=True)
        roles = user._page_roles = frozenset(names)
    return roles


def is_member(user) -> bool:
    """May use the pages: staff, or in the nurse or operator group."""
    return user.is_authenticated and (user.is_staff or bool(roles_of(user)))


def is_operator(user) -> bool:
    return user.is_authenticated and (user.is_staff or OPERATOR in roles_of(user))


def can_cancel(user, task) -> bool:
    """Operators cancel any task; other members only the ones they requested."""
    return is_operator(user) or (is_member(user) and task.requester_id == user.pk)


def member_required(view):
    """Log in first (redirect), then 403 for users in neither group and not staff."""

    @login_required
    @wraps(view)
    def guarded(request, *args, **kwargs):
        if not is_member(request.user):
            raise PermissionDenied("your account is in neither the nurse nor the operator group")
        return view(request, *args, **kwargs)

    return guarded


def operator_required(view):
    @member_required
    @wraps(view)
    def guarded(request, *args, **kwargs):
        if not is_operator(request.user):
            raise PermissionDenied("only operators may do this")
        return view(request, *args, **kwargs)

    return guarded


def is_admin(user) -> bool:
    """Administrators manage the sites' maps: staff users (they also reach the Django admin)."""
    return user.is_authenticated and user.is_staff


def admin_required(view):
    """Log in first (redirect), then 403 for anyone but an administrator."""

    @login_required
    @wraps(view)
    def guarded(request, *args, **kwargs):
        if not is_admin(request.user):
            raise PermissionDenied("only administrators may manage the site's map")
        return view(request, *args, **kwargs)

    return guarded
