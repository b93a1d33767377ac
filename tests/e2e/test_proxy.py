"""One port behind nginx (hospital_delivery/proxy.py), as scripts/run.sh runs it: pages, the
API and heartbeats to gunicorn, /ws/ to daphne, /static/ from nginx, slow clients buffered."""

import json
import shutil
import socket

import pytest
import requests
from websockets.sync.client import connect

from boards.services import board_post
from tests import factories, servers

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("nginx") is None, reason="./scripts/test.sh installs nginx"),
]

WORKERS = 2  # gunicorn's sync workers: as many slow clients would hold them all


@pytest.fixture(scope="module")
def stack(django_db_setup):
    with (
        servers.gunicorn(workers=WORKERS) as web,
        servers.daphne() as ws,
        servers.nginx(web_url=web, ws_url=ws.url) as proxy,
    ):
        yield web, proxy


def test_it_serves_pages_static_files_and_websockets_on_one_port(stack, transactional_db, site):
    _web, proxy = stack
    robot = factories.robot_create(site, "R1")

    page = requests.get(f"{proxy}/accounts/login/", timeout=30)
    script = requests.get(f"{proxy}/static/js/live.js", timeout=30)
    heartbeat = requests.post(
        f"{proxy}/api/v1/robots/R1/heartbeat",
        json=factories.heartbeat_body(1),
        headers={"Authorization": f"Bearer {robot.token}"},
        timeout=30,
    )

    assert page.status_code == 200
    assert "csrfmiddlewaretoken" in page.text
    assert script.status_code == 200
    assert script.headers["Server"] == "nginx"
    assert "new WebSocket" in script.text
    assert heartbeat.status_code == 200, heartbeat.text
    ws_url = proxy.replace("http://", "ws://") + "/ws/robots/R1"
    with connect(ws_url, additional_headers={"Authorization": f"Bearer {robot.token}"}) as socket_:
        message = board_post(robot=robot, type="action", body={"action": "pause"})
        wake = json.loads(socket_.recv(timeout=10))
    assert wake == {"type": "wake", "message": message.public_id}


def test_it_keeps_serving_while_slow_clients_trickle_their_bodies(stack):
    web, proxy = stack
    trickling = [_slow_client(web) for _ in range(WORKERS)]
    trickling += [_slow_client(proxy) for _ in range(2 * WORKERS)]
    try:
        # Without the proxy, WORKERS slow bodies hold every sync worker...
        with pytest.raises(requests.Timeout):
            requests.get(f"{web}/accounts/login/", timeout=1.5)
        # ...through it, twice as many are only nginx's business.
        answer = requests.get(f"{proxy}/accounts/login/", timeout=5)
        assert answer.status_code == 200
    finally:
        for client in trickling:
            client.close()


def test_it_sends_woken_heartbeats_to_their_own_socket(stack, transactional_db, site):
    """A heartbeat saying Woken-By goes to gunicorn's socket for woken heartbeats, which its
    workers take first; every other request to the regular one. Here only one of the two
    leads to a server, so the one that answers shows which the proxy chose."""
    web, _proxy = stack
    robot = factories.robot_create(site, "R1")
    nowhere = f"http://127.0.0.1:{servers.free_port()}"
    auth = {"Authorization": f"Bearer {robot.token}"}

    def heartbeat(proxy: str, seq: int, **headers) -> int:
        url = f"{proxy}/api/v1/robots/R1/heartbeat"
        body = factories.heartbeat_body(seq)
        return requests.post(url, json=body, headers={**auth, **headers}, timeout=30).status_code

    with servers.nginx(web_url=nowhere, ws_url=nowhere, web_woken_url=web) as woken_only:
        assert heartbeat(woken_only, 1, **{"Woken-By": "m-1"}) == 200
        assert heartbeat(woken_only, 2) == 502
    with servers.nginx(web_url=web, ws_url=nowhere, web_woken_url=nowhere) as regular_only:
        assert heartbeat(regular_only, 3) == 200
        assert heartbeat(regular_only, 4, **{"Woken-By": "m-1"}) == 502


def _slow_client(url: str) -> socket.socket:
    """A heartbeat whose body is announced as 100 bytes and sent one byte, then nothing."""
    host, port = url.split("://", 1)[1].split(":")
    client = socket.create_connection((host, int(port)))
    head = (
        "POST /api/v1/robots/R1/heartbeat HTTP/1.1\r\n"
        f"Host: {host}\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{{"
    )
    client.sendall(head.encode())
    return client
