"""Real servers for tests: gunicorn, daphne and a Celery worker, run the way production runs
them (docs/deployment/production.md), on the test database (and the test Redis database, from
REDIS_URL)."""

import os
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from contextlib import contextmanager
from pathlib import Path

from django.conf import settings

REPO = Path(__file__).resolve().parent.parent


CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def chromium_launch(playwright):
    """Debian's headless Chromium (CHROMIUM_PATH, default /usr/bin/chromium), never a browser
    Playwright downloaded: for the browser tests and docs/screenshots.py."""
    return playwright.chromium.launch(
        executable_path=os.environ.get("CHROMIUM_PATH", "/usr/bin/chromium"),
        headless=True,
        args=CHROMIUM_ARGS,
    )


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_database_url() -> str:
    """The URL of the database pytest-django created, for servers in other processes."""
    db = settings.DATABASES["default"]
    if db["ENGINE"] == "django.db.backends.sqlite3":
        return f"sqlite:///{db['NAME']}"
    return f"postgres://{db['USER']}:{db['PASSWORD']}@{db['HOST']}:{db['PORT']}/{db['NAME']}"


def wait_for_port(port: int, process: subprocess.Popen, *, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"server exited with {process.returncode} before listening")
        with socket.socket() as probe:
            if probe.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.05)
    raise TimeoutError(f"nothing listened on port {port} within {timeout} s")


@contextmanager
def gunicorn(*, workers: int = 2, env: dict | None = None, port: int | None = None):
    port = port or free_port()
    command = [
        *(sys.executable, "-m", "gunicorn", "tests.wsgi:application"),
        *("--bind", f"127.0.0.1:{port}", "--workers", str(workers)),
        *("--no-control-socket", "--log-level", "warning"),
    ]
    server_env = {
        **os.environ,
        "DATABASE_URL": test_database_url(),
        "DATABASE_CONN_MAX_AGE": "0",
        **(env or {}),
    }
    process = subprocess.Popen(command, cwd=REPO, env=server_env)
    try:
        wait_for_port(port, process)
        yield f"http://127.0.0.1:{port}"
    finally:
        process.terminate()
        process.wait(timeout=15)


@contextmanager
def nginx(*, web_url: str, ws_url: str, web_woken_url: str | None = None):
    """The proxy in front of them, configured as scripts/run.sh does (hospital_delivery/proxy.py),
    serving the repository's static/ directory; yields its http:// URL. Woken heartbeats go to
    `web_woken_url`, by default `web_url` (gunicorn as tests start it binds one socket)."""
    from hospital_delivery.proxy import Upstreams, nginx_config

    port = free_port()
    with tempfile.TemporaryDirectory(prefix="hd-nginx-") as runtime:
        for part in ("body", "proxy", "fastcgi", "uwsgi", "scgi"):
            os.mkdir(os.path.join(runtime, part))
        upstreams = Upstreams(
            listen=f"127.0.0.1:{port}",
            web=web_url.split("://", 1)[1],
            web_woken=(web_woken_url or web_url).split("://", 1)[1],
            ws=ws_url.split("://", 1)[1],
            static_root=REPO / "static",
            runtime=Path(runtime),
            user="root" if os.geteuid() == 0 else None,
        )
        config = Path(runtime) / "nginx.conf"
        config.write_text(nginx_config(upstreams))
        command = ["nginx", "-p", runtime, "-c", str(config), "-e", "stderr", "-g", "daemon off;"]
        process = subprocess.Popen(command)
        try:
            wait_for_port(port, process)
            yield f"http://127.0.0.1:{port}"
        finally:
            process.terminate()
            process.wait(timeout=15)


class Daphne:
    """daphne serving the Channels application (websockets), as the Procfile's `ws` process.

    It can be stopped and started again on the same port (a restart, as pages see it).
    """

    def __init__(self, env: dict | None = None):
        self.port, self.env, self.process = free_port(), server_env(env), None

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    def start(self) -> None:
        command = [
            *(sys.executable, "-m", "daphne", "--bind", "127.0.0.1", "--port", str(self.port)),
            *("--application-close-timeout", "3", "--verbosity", "0"),
            "hospital_delivery.asgi:application",
        ]
        self.process = subprocess.Popen(command, cwd=REPO, env=self.env)
        wait_for_port(self.port, self.process)

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait(timeout=5)


@contextmanager
def daphne(*, env: dict | None = None):
    """A running Daphne; give its url to gunicorn as WEBSOCKET_URL so pages connect to it."""
    server = Daphne(env)
    server.start()
    try:
        yield server
    finally:
        server.stop()


def server_env(env: dict | None = None) -> dict:
    return {
        **os.environ,
        "DATABASE_URL": test_database_url(),
        "DATABASE_CONN_MAX_AGE": "0",
        **(env or {}),
    }


def poll(check, *, timeout: float = 30.0, interval: float = 0.05, what: str = "condition"):
    """check()'s first truthy result, polling until `timeout` seconds have passed."""
    deadline = time.monotonic() + timeout
    while True:
        result = check()
        if result:
            return result
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what} not reached within {timeout} s")
        time.sleep(interval)


class CeleryWorker:
    """A `celery worker` process (solo pool) that consumes, and publishes to, one queue only,
    so that test sessions running side by side (pytest -n) never take each other's messages."""

    def __init__(self, app, queue: str, process: subprocess.Popen):
        self.app, self.queue, self.process = app, queue, process
        self.hostname = f"{queue}@{socket.gethostname()}"

    def ping(self) -> bool:
        if self.process.poll() is not None:
            raise RuntimeError(f"celery worker exited with {self.process.returncode}")
        return bool(self.app.control.ping(destination=[self.hostname], timeout=0.5))

    def is_idle(self) -> bool:
        """Nothing queued, nothing running, nothing reserved (a solo worker answers only when
        it is not running a task)."""
        with self.app.connection_for_read() as connection:
            if connection.default_channel.client.llen(self.queue):
                return False
        inspect = self.app.control.inspect(destination=[self.hostname], timeout=0.5)
        active, reserved = inspect.active() or {}, inspect.reserved() or {}
        return active.get(self.hostname) == [] and reserved.get(self.hostname) == []

    def wait_idle(self, timeout: float = 30.0) -> None:
        poll(self.is_idle, timeout=timeout, interval=0.1, what="an idle celery worker")


@contextmanager
def celery_sink(name: str):
    """Messages this process sends to Celery (allocation on commit) go to a queue of their own,
    which no worker reads, and which is deleted afterwards. Yields the queue's name, for
    servers started meanwhile (their CELERY_QUEUE)."""
    from hospital_delivery.celery import app

    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    queue = f"hd-test-{name}-{worker}-{uuid.uuid4().hex[:8]}"
    previous = app.conf.task_default_queue
    app.conf.task_default_queue = queue
    try:
        yield queue
    finally:
        app.conf.task_default_queue = previous
        celery_queue_delete(app, queue)


def celery_queue_delete(app, queue: str) -> None:
    """Remove a test queue and the routing keys Redis keeps for it."""
    with app.connection_for_write() as connection:
        client = connection.default_channel.client
        client.delete(queue, f"_kombu.binding.{queue}", f"_kombu.binding_permanent.{queue}")


@contextmanager
def celery_worker(*, queue: str, env: dict | None = None):
    """Run a Celery worker of the project on `queue` until the block ends."""
    from hospital_delivery.celery import app

    command = [sys.executable, "-m", "tests.servers", "celery-worker", queue]
    process = subprocess.Popen(command, cwd=REPO, env=server_env(env))
    worker = CeleryWorker(app, queue, process)
    try:
        poll(worker.ping, timeout=60, interval=0.2, what="a celery worker answering pings")
        yield worker
    finally:
        process.terminate()
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=5)
        celery_queue_delete(app, queue)


def _celery_worker_main(queue: str) -> None:
    """The worker process: `celery --app hospital_delivery worker`, except that the messages
    its tasks send (on_commit allocations) go to its own queue rather than the default."""
    from hospital_delivery.celery import app

    app.conf.task_default_queue = queue
    app.worker_main(
        [
            *("worker", "--pool", "solo", "--queues", queue, "--hostname", f"{queue}@%h"),
            *("--without-mingle", "--without-gossip", "--loglevel", "WARNING"),
        ]
    )


if __name__ == "__main__":
    if sys.argv[1:2] == ["celery-worker"]:
        _celery_worker_main(sys.argv[2])
