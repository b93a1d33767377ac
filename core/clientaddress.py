"""The address of the client that sent a request, as the proxies in front of Django saw it.

Behind nginx (hospital_delivery/proxy.py) every request comes from the proxy's own address, so
REMOTE_ADDR names nobody. Each proxy appends the address it received the request from to
X-Forwarded-For; a client can put anything in front of that list, but not after it. So with
settings.TRUSTED_PROXY_COUNT proxies, the client is the entry that many places from the
right: what the outermost trusted proxy saw. With 0 (Django reached directly) it is
REMOTE_ADDR, and so it is when the header has fewer entries than there are proxies (a request
that did not come through them).

django-axes' lock-outs (settings.AXES_CLIENT_IP_CALLABLE) and the sign-in throttle
(hospital_delivery/signin.py) both count by this address.
"""

import ipaddress

from django.conf import settings


def client_address(request) -> str:
    remote = request.META.get("REMOTE_ADDR", "")
    count = settings.TRUSTED_PROXY_COUNT
    if count == 0:
        return remote
    forwarded = request.META.get("HTTP_X_FORWARDED_FOR", "")
    hops = [hop.strip() for hop in forwarded.split(",") if hop.strip()]
    if len(hops) < count:
        return remote
    try:
        return str(ipaddress.ip_address(hops[-count]))
    except ValueError:
        return remote
