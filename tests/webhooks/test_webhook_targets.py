"""Webhooks cannot be turned into a way inside: internal addresses refused at save and at every
send (after DNS resolution), redirects never followed, the connection pinned to the checked
address, and the page shows only a status and a fixed reason.

The receivers listen on 127.0.0.1 (the only addresses tests may reach): each test that needs a
delivery allows that network, and the refusals are shown without it. The other internal ranges
are checked by the address rule alone, which connects nowhere.
"""

import ipaddress
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest
from django.core.exceptions import ValidationError
from django.test import Client

from tests import factories
from tests.scheduling.conftest import request as task_request
from tests.webhooks.conftest import subscribe
from tests.webhooks.receiver import HookReceiver
from webhooks import targets
from webhooks.models import Subscription, WebhookDelivery
from webhooks.services import delivery_send

pytestmark = pytest.mark.django_db


class Answering:
    """A receiver that answers every request with one fixed status, headers and body, and
    records the requests' paths and Host headers."""

    def __init__(self, status: int, *, headers: dict | None = None, body: bytes = b""):
        self.requests: list[tuple[str, str, str]] = []
        receiver = self

        class Handler(BaseHTTPRequestHandler):
            def _answer(self):
                length = int(self.headers.get("Content-Length", 0))
                self.rfile.read(length)
                receiver.requests.append((self.command, self.path, self.headers.get("Host")))
                self.send_response(status)
                for name, value in (headers or {}).items():
                    self.send_header(name, value)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            do_GET = do_POST = _answer  # noqa: N815 (http.server's names)

            def log_message(self, *args):
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.port = self.server.server_address[1]
        self.url = f"http://127.0.0.1:{self.port}/hook"

    def __enter__(self):
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        return self

    def __exit__(self, *exc):
        self.server.shutdown()
        self.server.server_close()


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def one_delivery(site) -> WebhookDelivery:
    task_request(site)
    return WebhookDelivery.objects.get()


@pytest.mark.parametrize("host", ["127.0.0.1", "localhost", "[::1]", "0.0.0.0"])
def test_it_refuses_an_internal_url_at_save_naming_the_field(site, settings, host):
    settings.WEBHOOK_ALLOWED_NETWORKS = []

    with pytest.raises(ValidationError) as refused:
        subscribe(site, f"http://{host}:8000/internal")

    assert "inside the hospital's network" in refused.value.message_dict["url"][0]
    assert not Subscription.objects.exists()


def test_an_allowed_network_is_accepted(site, settings):
    settings.WEBHOOK_ALLOWED_NETWORKS = ["127.0.0.1/32"]
    subscribe(site, "http://127.0.0.1:8000/hook")
    settings.WEBHOOK_ALLOWED_NETWORKS = ["10.0.0.0/8"]
    with pytest.raises(ValidationError):
        subscribe(site, "http://127.0.0.2:8000/hook")


def test_the_admin_refuses_an_internal_url(site, settings):
    settings.WEBHOOK_ALLOWED_NETWORKS = []
    admin = Client()
    admin.force_login(factories.user_create("root", is_staff=True, is_superuser=True))

    page = admin.post(
        "/admin/webhooks/subscription/add/",
        {
            "site": site.pk,
            "name": "Scanner",
            "url": "http://localhost:6379/",
            "secret": "s",
            "statuses": "[]",
            "active": "on",
            "created_at_0": "2026-11-27",
            "created_at_1": "10:00",
        },
    )

    assert page.status_code == 200  # the form again, with its error
    assert "inside the hospital&#x27;s network" in page.content.decode()
    assert not Subscription.objects.exists()


def test_it_refuses_at_send_when_the_address_is_no_longer_allowed(site, settings, sent):
    with HookReceiver() as receiver:
        subscribe(site, receiver.url)  # saved while the network was allowed
        delivery = one_delivery(site)
        settings.WEBHOOK_ALLOWED_NETWORKS = []

        assert delivery_send(delivery_id=delivery.pk) is False

    assert receiver.received == []
    delivery.refresh_from_db()
    assert (delivery.last_status_code, delivery.last_error) == (None, "address_refused")


@pytest.mark.parametrize("status", [301, 302, 303, 307, 308])
def test_it_never_follows_a_redirect(site, sent, status):
    with HookReceiver() as inside, Answering(status, headers={"Location": inside.url}) as hook:
        subscribe(site, hook.url)
        delivery = one_delivery(site)

        assert delivery_send(delivery_id=delivery.pk) is False

    assert inside.received == []  # the signed POST went nowhere else
    assert [method for method, _, _ in hook.requests] == ["POST"]
    delivery.refresh_from_db()
    assert (delivery.state, delivery.last_status_code) == ("pending", status)
    assert delivery.get_last_error_display() == "Answered with a redirect, which is never followed"


def test_the_page_shows_only_a_status_and_a_fixed_reason(site, operator, sent):
    secret = b"internal-admin-password: hunter2"
    with Answering(500, body=secret) as talkative:
        subscribe(site, talkative.url, name="Talkative")
        subscribe(site, f"http://127.0.0.1:{closed_port()}/hook", name="Closed port")
        task_request(site)
        for delivery in WebhookDelivery.objects.all():
            delivery_send(delivery_id=delivery.pk)
    client = Client()
    client.force_login(operator)

    page = client.get("/webhooks/").content.decode()

    assert "hunter2" not in page
    assert "Connection" not in page
    assert "Errno" not in page
    assert "refused" not in page
    assert "Answered with a status other than 2xx" in page
    assert "No connection could be made" in page


def test_it_connects_to_the_address_it_checked(site, sent, monkeypatch):
    # A host name that resolves differently on each lookup (DNS rebinding) is looked up once
    # per send: the address checked is the address connected to, and the host is named in the
    # Host header.
    lookups = []
    real = socket.getaddrinfo

    def rebinding(host, port, *args, **kwargs):
        if host == "lab.hospital.test":
            lookups.append(host)
            answer = "127.0.0.1" if len(lookups) == 1 else "127.0.0.2"
            return real(answer, port, *args, **kwargs)
        return real(host, port, *args, **kwargs)

    with Answering(204) as hook:
        subscribe(site, hook.url)  # a subscription made while 127.0.0.0/8 is allowed
        Subscription.objects.update(url=f"http://lab.hospital.test:{hook.port}/hook?x=1")
        delivery = one_delivery(site)
        monkeypatch.setattr(targets.socket, "getaddrinfo", rebinding)

        assert delivery_send(delivery_id=delivery.pk) is True

    assert lookups == ["lab.hospital.test"]
    assert hook.requests == [("POST", "/hook?x=1", f"lab.hospital.test:{hook.port}")]


@pytest.mark.parametrize(
    "address",
    [
        "10.1.2.3",
        "172.16.0.1",
        "192.168.1.10",
        "100.64.0.1",  # shared (carrier-grade NAT)
        "169.254.169.254",  # link-local: cloud metadata
        "224.0.0.1",
        "239.255.255.250",
        "0.0.0.0",
        "240.0.0.1",
        "127.0.0.1",
        "::1",
        "::",
        "fe80::1",
        "fc00::1",
        "ff02::1",
        "::ffff:10.0.0.1",
        "::ffff:127.0.0.1",
    ],
)
def test_internal_addresses_are_refused_unless_listed(address):
    ip = ipaddress.ip_address(address)
    assert targets.address_refused(ip, allowed=[])
    listed = ipaddress.ip_network(f"{address}/{ip.max_prefixlen}")
    assert not targets.address_refused(ip, allowed=[listed])


def test_public_addresses_pass_and_the_servers_own_do_not():
    assert not targets.address_refused(ipaddress.ip_address("93.184.216.34"), allowed=[])
    assert not targets.address_refused(ipaddress.ip_address("2606:4700::1"), allowed=[])
    # Whether an address is the server's own is asked of the system (a bind), nothing is sent.
    assert targets.is_own_address(ipaddress.ip_address("127.0.0.1"))
    assert not targets.is_own_address(ipaddress.ip_address("192.0.2.1"))


@pytest.mark.parametrize("url", ["ftp://example.org/x", "http:///nohost", "file:///etc/passwd"])
def test_only_http_urls_with_a_host_are_accepted(site, url):
    with pytest.raises(ValidationError) as refused:
        subscribe(site, url)
    assert "url" in refused.value.message_dict
