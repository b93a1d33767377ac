"""Who is acting, and from where, for the entries written while a request is served.

django-auditlog ships a middleware for this, but it connects and disconnects a signal receiver
on every request (including every robot heartbeat, which is not audited) and takes the first
X-Forwarded-For entry, which any client can write. This one only sets a context variable, read
when an entry is written; the address is the one core.clientaddress trusts (what the proxies of
settings.TRUSTED_PROXY_COUNT saw), as for the sign-in throttle and django-axes.
"""

from audit.context import request_context


class AuditContextMiddleware:
    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        with request_context(request):
            return self.get_response(request)
