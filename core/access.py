"""Who may use the pages: Django groups `nurse` and `operator` (created by a data migration).

Any user in either group, or a staff user, may use the pages and order deliveries; nurses may
cancel their own requests; operators (and staff) may cancel any task, pause, resume and return
robots and acknowledge alerts. Views enforce this on the server (the templates only hide what
a user may not do).

A third group, `integration`, is for hospital systems (the pharmacy's, the laboratory's) that
order over FHIR (fhir/): they order, read and cancel their own orders at their sites, and open
no page and operate no robot.

A fourth, `auditor`, reads the audit trail of its sites (audit/) and nothing else: auditors
are often from outside the wards (information security, the pharmacy's controlled-drugs
officer), so the role gives no page of the fleet.
"""

from functools import wraps

from django.contrib.auth.decorators import login_required
from django.core.exceptions import PermissionDenied

NURSE = "nurse"
OPERATOR = "operator"
GROUPS = (NURSE, OPERATOR)  # the page groups
INTEGRATION = "integration"
AUDITOR = "auditor"
ROLES = (*GROUPS, INTEGRATION, AUDITOR)


def roles_of(user) -> frozenset[str]:
    """The user's groups among ROLES, read once per request (cached on the user object)."""
    if not user.is_authenticated:
        return frozenset()
    roles = getattr(user, "_page_roles", None)
    if roles is None:
        names = user.groups.filter(name__in=ROLES).values_list("name", flat=True)
        roles = user._page_roles = frozenset(names)
    return roles


def is_member(user) -> bool:
    """May use the pages: staff, or in the nurse or operator group."""
    return user.is_authenticated and (user.is_staff or bool(roles_of(user) & set(GROUPS)))


def is_integration(user) -> bool:
    """May order and read deliveries over FHIR: staff, or in the integration group."""
    return user.is_authenticated and (user.is_staff or INTEGRATION in roles_of(user))


def is_operator(user) -> bool:
    return user.is_authenticated and (user.is_staff or OPERATOR in roles_of(user))


def can_cancel(user, task) -> bool:
    """Operators cancel any task; other members and hospital systems only the ones they
    requested."""
    may_order = is_member(user) or is_integration(user)
    return is_operator(user) or (may_order and task.requester_id == user.pk)


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


def is_auditor(user) -> bool:
    """May read the audit trail: staff (every site), or in the auditor group (its sites)."""
    return user.is_authenticated and (user.is_staff or AUDITOR in roles_of(user))


def auditor_required(view):
    """Log in first (redirect), then 403 for anyone but an auditor or an administrator."""

    @login_required
    @wraps(view)
    def guarded(request, *args, **kwargs):
        if not is_auditor(request.user):
            raise PermissionDenied("only auditors and administrators may read the audit trail")
        return view(request, *args, **kwargs)

    return guarded
