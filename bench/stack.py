"""The production stack as subprocesses, for benchmarks and end-to-end tests.

What the Procfile runs: gunicorn with N sync workers for HTTP (its socket for woken heartbeats
first, as there), daphne for websockets, a Celery worker (prefork, 2 processes) and, optionally,
Celery beat and nginx in front (proxy=True: `proxy_url` then reaches everything on one port,
as robots and browsers do in production), all on one database and one Redis.
Two stacks can run side by side on one Redis (pytest -n, or a benchmark next to the demo):
each gets a Celery queue and a Channels prefix of its own.

    with temporary_database("postgres://postgres@127.0.0.1:5432/postgres") as url:
        with Stack(database_url=url, web_workers=3, beat=True) as stack:
            requests.get(stack.http_url + "/api/schema/")

Everything is stopped on exit (SIGTERM to each process group, SIGKILL after a grace period),
and the queue's keys are removed from Redis.

Run as a module, it is the entry point of the Celery processes it starts:
`python -m bench.stack worker QUEUE CONCURRENCY` / `python -m bench.stack beat QUEUE FILE`.
"""

from __future__ import annotations

import contextlib
import hashlib
import http.client
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from contextlib import contextmanager
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

REPO = Path(__file__).resolve().parent.parent
QUEUE_VARIABLE = "STACK_CELERY_QUEUE"  # read by bench/wsgi.py and the Celery entry points


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def database_option(parser) -> None:
    """A benchmark's --database: the server (and role) where it makes its throwaway database
    (temporary_database), by default DATABASE_URL's."""
    parser.add_argument(
        "--database",
        default=os.environ.get(
            "DATABASE_URL", "postgres://hospital_delivery@127.0.0.1:5432/postgres"
        ),
        help="server (and role) for the throwaway database",
    )


def queue_forget(redis_url: str, queue: str) -> None:
    """Remove a Celery queue of a benchmark's own from Redis, with what kombu keeps of it."""
    import redis

    client = redis.Redis.from_url(redis_url, socket_timeout=2, socket_connect_timeout=2)
    try:
        client.delete(queue, f"_kombu.binding.{queue}", f"_kombu.binding_permanent.{queue}")
    except redis.RedisError:
        pass  # a stalled Redis (SilentRedis) holds no queue to forget
    finally:
        client.close()


def _port_open(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


def _http_answers(port: int) -> bool:
    """Whether a web worker behind `port` answers HTTP: gunicorn's master listens before its
    workers have loaded Django, which takes seconds on a busy machine. Any status will do (the
    bare endpoint answers a GET with 405, touching neither the database nor Redis)."""
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=2)
    try:
        connection.request("GET", "/bench/bare")
        connection.getresponse()
        return True
    except (OSError, http.client.HTTPException):  # refused, timed out, or cut off mid-answer
        return False
    finally:
        connection.close()


class StackError(RuntimeError):
    pass


class Stack:
    """gunicorn + daphne + Celery worker (+ beat) on `database_url`; a context manager."""

    def __init__(
        self,
        *,
        database_url: str,
        redis_url: str | None = None,
        web_workers: int = 3,
        daphne: bool = True,
        worker: bool = True,
        worker_concurrency: int = 2,
        beat: bool = False,
        conn_max_age: int | None = None,
        env: dict | None = None,
        proxy: bool = False,
    ):
        self.database_url = database_url
        self.redis_url = redis_url or os.environ.get("REDIS_URL", "redis://127.0.0.1:6379/0")
        self.web_workers = web_workers
        self.with_daphne, self.with_worker, self.with_beat = daphne, worker, beat
        self.with_proxy = proxy and daphne
        self.worker_concurrency = worker_concurrency
        self.queue = f"hd-stack-{uuid.uuid4().hex[:10]}"
        self.channels_prefix = self.queue
        self.http_port = free_port()
        self.woken_port = free_port()  # heartbeats a wake caused (hospital_delivery/proxy.py)
        self.proxy_port = free_port() if self.with_proxy else None
        self.ws_port = free_port() if daphne else None
        self.logs = Path(tempfile.mkdtemp(prefix="hd-stack-"))
        self.env = {
            **os.environ,
            "DATABASE_URL": database_url,
            "REDIS_URL": self.redis_url,
            "CHANNELS_PREFIX": self.channels_prefix,
            QUEUE_VARIABLE: self.queue,
            "PYTHONUNBUFFERED": "1",
            **({"DATABASE_CONN_MAX_AGE": str(conn_max_age)} if conn_max_age is not None else {}),
            **(env or {}),
        }
        self.processes: dict[str, subprocess.Popen] = {}

    @property
    def http_url(self) -> str:
        return f"http://127.0.0.1:{self.http_port}"

    @property
    def ws_url(self) -> str | None:
        return f"ws://127.0.0.1:{self.ws_port}" if self.ws_port else None

    @property
    def proxy_url(self) -> str | None:
        return f"http://127.0.0.1:{self.proxy_port}" if self.proxy_port else None

    @property
    def proxy_ws_url(self) -> str | None:
        return f"ws://127.0.0.1:{self.proxy_port}" if self.proxy_port else None

    @property
    def description(self) -> str:
        parts = [f"gunicorn {self.web_workers} sync workers"]
        if self.with_daphne:
            parts.append("daphne")
        if self.with_worker:
            parts.append(f"Celery worker (prefork, {self.worker_concurrency})")
        if self.with_beat:
            parts.append("Celery beat")
        if self.with_proxy:
            parts.append("nginx in front")
        return ", ".join(parts)

    def __enter__(self) -> Stack:
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    # --- Starting -------------------------------------------------------------------------

    def start(self) -> None:
        python = sys.executable
        self._spawn(
            "web",
            [
                *(python, "-m", "gunicorn", "bench.wsgi:application"),
                *("--bind", f"127.0.0.1:{self.woken_port}"),
                *("--bind", f"127.0.0.1:{self.http_port}", "--worker-class", "sync"),
                *("--workers", str(self.web_workers), "--graceful-timeout", "4"),
                *("--no-control-socket", "--log-level", "warning"),
            ],
        )
        if self.with_daphne:
            self._spawn(
                "ws",
                [
                    *(python, "-m", "daphne", "--bind", "127.0.0.1", "--port", str(self.ws_port)),
                    *("--application-close-timeout", "3", "-v", "0"),
                    "hospital_delivery.asgi:application",
                ],
            )
        if self.with_worker:
            concurrency = str(self.worker_concurrency)
            self._spawn("worker", [python, "-m", "bench.stack", "worker", self.queue, concurrency])
        if self.with_beat:
            schedule = str(self.logs / "celerybeat-schedule")
            self._spawn("beat", [python, "-m", "bench.stack", "beat", self.queue, schedule])
        if self.with_proxy:
            self._spawn("proxy", self._nginx_command())
        self._wait_answering("web", self.http_port)
        if self.with_daphne:
            self._wait_port("ws", self.ws_port)
        if self.with_proxy:
            self._wait_port("proxy", self.proxy_port)
        if self.with_worker:
            self._wait_worker()

    def _nginx_command(self) -> list[str]:
        """nginx configured as scripts/run.sh configures it (hospital_delivery/proxy.py)."""
        from hospital_delivery.proxy import Upstreams, nginx_config

        runtime = self.logs / "nginx"
        for part in ("body", "proxy", "fastcgi", "uwsgi", "scgi"):
            (runtime / part).mkdir(parents=True)
        upstreams = Upstreams(
            listen=f"127.0.0.1:{self.proxy_port}",
            web=f"127.0.0.1:{self.http_port}",
            web_woken=f"127.0.0.1:{self.woken_port}",
            ws=f"127.0.0.1:{self.ws_port}",
            static_root=REPO / "static",
            runtime=runtime,
            user="root" if os.geteuid() == 0 else None,
        )
        (runtime / "nginx.conf").write_text(nginx_config(upstreams))
        options = ("-c", "nginx.conf", "-e", "stderr", "-g", "daemon off;")
        return ["nginx", "-p", str(runtime), *options]

    def _spawn(self, name: str, command: list[str]) -> None:
        log = (self.logs / f"{name}.log").open("wb")
        self.processes[name] = subprocess.Popen(
            command,
            cwd=REPO,
            env=self.env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: stopped with all its children
        )

    def _wait_port(self, name: str, port: int, timeout: float = 60.0) -> None:
        self._wait(name, lambda: _port_open(port), timeout, f"listening on {port}")

    def _wait_answering(self, name: str, port: int, timeout: float = 60.0) -> None:
        self._wait(name, lambda: _http_answers(port), timeout, f"answering HTTP on {port}")

    def _wait_worker(self, timeout: float = 60.0) -> None:
        from celery import Celery

        # Not the current app: in a test process, tasks would be sent through this one.
        pinger = Celery(broker=self.redis_url, set_as_current=False)
        destination = [f"{self.queue}@{socket.gethostname()}"]
        try:
            self._wait(
                "worker",
                lambda: bool(pinger.control.ping(destination=destination, timeout=0.5)),
                timeout,
                "answering pings",
            )
        finally:
            pinger.close()

    def _wait(self, name: str, ready, timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not ready():
            process = self.processes[name]
            if process.poll() is not None:
                raise StackError(f"{name} exited with {process.returncode}:\n{self.log_tail(name)}")
            if time.monotonic() > deadline:
                raise StackError(f"{name} not {what} within {timeout} s:\n{self.log_tail(name)}")
            time.sleep(0.05)

    def log_tail(self, name: str, lines: int = 40) -> str:
        path = self.logs / f"{name}.log"
        text = path.read_text(errors="replace") if path.exists() else ""
        return "\n".join(text.splitlines()[-lines:])

    def alive(self) -> dict[str, bool]:
        return {name: process.poll() is None for name, process in self.processes.items()}

    # --- Stopping -------------------------------------------------------------------------

    def stop(self, grace: float = 10.0) -> None:
        """Stop every process group we started (beat first, web last), SIGKILL laggards.

        When a stack stops, its run is over: gunicorn and the Celery worker get their quick
        shutdown (SIGQUIT), not the graceful one, which waits seconds for idle workers. The
        others SIGTERM."""
        names = ("proxy", "beat", "worker", "ws", "web")
        order = [name for name in names if name in self.processes]
        for name in order:
            quick = name in ("web", "worker")
            _signal_group(self.processes[name], signal.SIGQUIT if quick else signal.SIGTERM)
        deadline = time.monotonic() + grace
        for name in order:
            process = self.processes[name]
            try:
                process.wait(timeout=max(deadline - time.monotonic(), 0.1))
            except subprocess.TimeoutExpired:
                _signal_group(process, signal.SIGKILL)
                process.wait(timeout=5)
        self.processes.clear()
        self._forget_queue()

    def _forget_queue(self) -> None:
        queue_forget(self.redis_url, self.queue)


class SilentRedis:
    """Accepts every connection and never reads or answers, like a wedged Redis: for a server
    run with REDIS_URL = silent.url. A context manager."""

    def __init__(self):
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.held: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def _accept(self):
        while True:
            try:
                connection, _ = self.listener.accept()
            except OSError:
                return
            self.held.append(connection)

    def close(self):
        self.listener.close()
        for connection in self.held:
            connection.close()

    def __enter__(self) -> SilentRedis:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _signal_group(process: subprocess.Popen, signum: int) -> None:
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signum)  # the group this Stack created for it


# --- Databases -----------------------------------------------------------------------------------


def manage(*args: str, database_url: str, env: dict | None = None) -> str:
    """Run `manage.py ARGS` on `database_url`; returns its output, raises on failure."""
    finished = subprocess.run(
        [sys.executable, "manage.py", *args],
        cwd=REPO,
        env={**os.environ, "DATABASE_URL": database_url, **(env or {})},
        capture_output=True,
        text=True,
        check=False,
    )
    if finished.returncode:
        raise StackError(f"manage.py {' '.join(args)} failed:\n{finished.stdout}{finished.stderr}")
    return finished.stdout


@contextmanager
def temporary_database(base_url: str, *, migrate: bool = True):
    """A fresh database next to `base_url` (PostgreSQL: a new database on that server, created
    with that role and dropped afterwards; SQLite: a file in a temporary directory), migrated.
    Yields its URL."""
    parts = urlsplit(base_url)
    if parts.scheme.startswith("sqlite"):
        with tempfile.TemporaryDirectory(prefix="hd-bench-") as directory:
            url = f"sqlite:///{directory}/bench.sqlite3"
            if migrate:
                manage("migrate", "--noinput", "-v", "0", database_url=url)
            yield url
        return
    name = f"hd_bench_{uuid.uuid4().hex[:10]}"
    copied = f' TEMPLATE "{_migrated_template(base_url)}"' if migrate else ""
    _postgres_admin(base_url, f'CREATE DATABASE "{name}"{copied}')
    try:
        yield _on_database(base_url, name)
    finally:
        _postgres_admin(base_url, f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


def _migrated_template(base_url: str) -> str:
    """The name of a database on `base_url`'s server migrated as the code's migrations say,
    made the first time they are asked for and copied for every benchmark after: copying takes
    a second, migrating a fresh database ten or more. Its name carries a digest of the
    migration files, so a changed migration makes a new one (and the old ones are dropped).
    Made under an advisory lock, as benchmarks and test workers may ask at the same moment."""
    digest = hashlib.sha256()
    for path in sorted(REPO.glob("*/migrations/*.py")):
        digest.update(path.relative_to(REPO).as_posix().encode() + path.read_bytes())
    name = f"hd_bench_template_{digest.hexdigest()[:12]}"
    with _postgres_connection(base_url) as connection:
        connection.execute("SELECT pg_advisory_lock(hashtext('hd_bench_template'))")
        made = connection.execute(
            "SELECT datname FROM pg_database WHERE datname LIKE 'hd_bench_template_%'"
        )
        existing = [row[0] for row in made.fetchall()]
        if name not in existing:
            for old in existing:
                connection.execute(f'DROP DATABASE IF EXISTS "{old}" WITH (FORCE)')
            _template_make(connection, base_url, name)
    return name


def _template_make(connection, base_url: str, name: str) -> None:
    """Migrate a database under a provisional name, then give it `name`: a run stopped halfway
    leaves no template that looks complete."""
    making = f"{name}_making"
    connection.execute(f'DROP DATABASE IF EXISTS "{making}" WITH (FORCE)')
    connection.execute(f'CREATE DATABASE "{making}"')
    manage("migrate", "--noinput", "-v", "0", database_url=_on_database(base_url, making))
    connection.execute(f'ALTER DATABASE "{making}" RENAME TO "{name}"')


def _on_database(base_url: str, name: str) -> str:
    return urlunsplit(urlsplit(base_url)._replace(path=f"/{name}"))


def _postgres_admin(base_url: str, statement: str) -> None:
    """Run `statement` on the server of `base_url`: in its database, or else in `postgres`."""
    with _postgres_connection(base_url) as connection:
        connection.execute(statement)


def _postgres_connection(base_url: str):
    """An autocommit connection to the server of `base_url`: to its database, or else to
    `postgres`."""
    import psycopg

    parts = urlsplit(base_url)
    server = {
        "host": parts.hostname or "127.0.0.1",
        "port": parts.port or 5432,
        "user": parts.username or "postgres",
        "password": parts.password,
        "autocommit": True,
    }
    try:
        return psycopg.connect(dbname=parts.path.lstrip("/") or "postgres", **server)
    except psycopg.OperationalError:
        return psycopg.connect(dbname="postgres", **server)


# --- Celery entry points (run in the subprocesses) ---------------------------------------------


def _celery_app(queue: str):
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")
    import django

    django.setup()
    from hospital_delivery.celery import app

    app.conf.task_default_queue = queue  # what it sends (on-commit allocations) stays here
    return app


def _worker_main(queue: str, concurrency: str) -> None:
    _celery_app(queue).worker_main(
        [
            *("worker", "--queues", queue, "--hostname", f"{queue}@%h"),
            *("--concurrency", concurrency, "--without-mingle", "--without-gossip"),
            *("--loglevel", "WARNING"),
        ]
    )


def _beat_main(queue: str, schedule: str) -> None:
    _celery_app(queue).start(["beat", "--schedule", schedule, "--loglevel", "WARNING"])


if __name__ == "__main__":
    command, *arguments = sys.argv[1:]
    {"worker": _worker_main, "beat": _beat_main}[command](*arguments)
