"""Where a webhook may be sent: never inside the hospital's network or the server itself.

A subscription's URL is an address the server will POST to on its own, so an operator (or
whoever can change a subscription) must not be able to point it at internal services. Its
host is resolved and every address it resolves to checked, at save and again at every send;
the send then connects to the address that was checked (pinned), so a DNS answer that
changes between the check and the connection cannot lead it elsewhere.

Refused unless inside one of settings.WEBHOOK_ALLOWED_NETWORKS: loopback, private, shared
(carrier-grade NAT), link-local, multicast, unspecified and reserved addresses, and any
address of the server's own interfaces.
"""

import ipaddress
import socket
from dataclasses import dataclass
from urllib.parse import unquote, urlsplit

import urllib3
from django.conf import settings
from urllib3 import exceptions as http_errors

from webhooks.choices import AttemptFailure

Address = ipaddress.IPv4Address | ipaddress.IPv6Address

SCHEMES = {"http": 80, "https": 443}


class TargetRefused(Exception):
    """A URL the server must not (or could not) send to; `reason` is an AttemptFailure."""

    def __init__(self, reason: AttemptFailure):
        super().__init__(reason.label)
        self.reason = reason


@dataclass(frozen=True)
class Target:
    """A checked URL: connect to `address`, speak to `host` (Host header, TLS name)."""

    scheme: str
    host: str
    port: int
    address: str
    path: str  # path and query, as sent in the request line
    userinfo: str  # "user:password" from the URL, sent as basic authentication, or ""

    @property
    def host_header(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return host if self.port == SCHEMES[self.scheme] else f"{host}:{self.port}"


def allowed_networks() -> list[ipaddress.IPv4Network | ipaddress.IPv6Network]:
    return [ipaddress.ip_network(each, strict=False) for each in settings.WEBHOOK_ALLOWED_NETWORKS]


def address_refused(address: Address, allowed=None) -> bool:
    """True for an address a webhook must not reach (see the module's docstring)."""
    allowed = allowed_networks() if allowed is None else allowed
    if any(address in network for network in allowed if network.version == address.version):
        return False
    mapped = getattr(address, "ipv4_mapped", None)
    if mapped is not None:
        return address_refused(mapped, allowed)
    # Not global: loopback, private, shared, link-local, unspecified and reserved ranges (the
    # IANA special-purpose registries); multicast ranges count as global there.
    inside = not address.is_global or address.is_multicast
    return inside or is_own_address(address)


def is_own_address(address: Address) -> bool:
    """Whether the address belongs to one of this machine's interfaces: the system lets a
    socket bind only to its own addresses."""
    family = socket.AF_INET if address.version == 4 else socket.AF_INET6
    try:
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((str(address), 0))
    except OSError:
        return False
    return True


def target_check(url: str) -> Target:
    """The URL resolved and checked, ready to connect to; TargetRefused otherwise."""
    parts = urlsplit(url)
    if parts.scheme not in SCHEMES or not parts.hostname:
        raise TargetRefused(AttemptFailure.NOT_HTTP)
    try:
        port = parts.port or SCHEMES[parts.scheme]
    except ValueError:
        raise TargetRefused(AttemptFailure.NOT_HTTP) from None
    addresses = _resolve(parts.hostname, port)
    allowed = allowed_networks()
    if any(address_refused(address, allowed) for address in addresses):
        raise TargetRefused(AttemptFailure.ADDRESS_REFUSED)
    path = parts.path or "/"
    userinfo = parts.netloc.rpartition("@")[0] if "@" in parts.netloc else ""
    return Target(
        scheme=parts.scheme,
        host=parts.hostname,
        port=port,
        address=str(addresses[0]),
        path=f"{path}?{parts.query}" if parts.query else path,
        userinfo=userinfo,
    )


def _resolve(host: str, port: int) -> list[Address]:
    try:
        found = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError):
        raise TargetRefused(AttemptFailure.UNRESOLVED) from None
    addresses = []
    for *_, sockaddr in found:
        address = ipaddress.ip_address(sockaddr[0].partition("%")[0])
        if address not in addresses:
            addresses.append(address)
    if not addresses:
        raise TargetRefused(AttemptFailure.UNRESOLVED)
    return addresses


def target_post(target: Target, *, body: bytes, headers: dict, timeout: float) -> int:
    """POST to the checked address and return the answer's status, its body unread; never
    follows a redirect. TargetRefused(reason) when no answer came."""
    headers = {**headers, "Host": target.host_header}
    if target.userinfo:
        user, _, password = target.userinfo.partition(":")
        auth = f"{unquote(user)}:{unquote(password)}"
        headers.update(urllib3.util.make_headers(basic_auth=auth))
    pool = _pool(target, timeout)
    try:
        response = pool.urlopen(
            "POST",
            target.path,
            body=body,
            headers=headers,
            redirect=False,
            retries=False,
            preload_content=False,
        )
        response.release_conn()
        return response.status
    except http_errors.NewConnectionError:
        raise TargetRefused(AttemptFailure.UNREACHABLE) from None
    except http_errors.TimeoutError:
        raise TargetRefused(AttemptFailure.TIMEOUT) from None
    except http_errors.SSLError:
        raise TargetRefused(AttemptFailure.TLS) from None
    except (http_errors.HTTPError, OSError):
        raise TargetRefused(AttemptFailure.BAD_ANSWER) from None
    finally:
        pool.close()


def _pool(target: Target, timeout: float) -> urllib3.HTTPConnectionPool:
    """A connection to the pinned address that still names the host: in the Host header, and
    for HTTPS in the TLS server name and the certificate's check (the system's CAs)."""
    if target.scheme == "https":
        return urllib3.HTTPSConnectionPool(
            target.address,
            target.port,
            timeout=timeout,
            retries=False,
            cert_reqs="CERT_REQUIRED",
            server_hostname=target.host,
            assert_hostname=target.host,
        )
    return urllib3.HTTPConnectionPool(target.address, target.port, timeout=timeout, retries=False)
