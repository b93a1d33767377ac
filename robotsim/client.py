"""Reference robot-side client for the robot ⇄ server protocol v1 (robot-protocol.md).

This is what a robot integrator starts from. It speaks only HTTP (and, optionally, the push
websocket); it imports nothing from the server. It keeps the protocol's promises on the robot
side:

* every event is kept until a heartbeat that carried it is answered (then the server has it:
  events are applied exactly once by id, so resending is always safe);
* acks and resource requests likewise travel until answered;
* board messages are applied once each, de-duplicated by id, and acked after they are applied;
* a plan is applied only when its plan_version is newer than the one applied;
* `seq` grows by one per heartbeat and `boot_id` is new each time the software starts;
* an event or request the server refuses (400 naming it) can be dropped, so that one bad item
  does not block every later heartbeat (drop_refused);
* with the optional push channel (listen_for_wakes) it heartbeats at once when woken, saying
  so (`Woken-By`: the server answers it ahead of the regular heartbeats), and once after every
  (re)connection, for whatever was posted while the socket was down;
* a secure delivery's PIN is checked on the robot, without the network (pin_check, with the
  plan task's `secure`), so a dead zone at the station never keeps a recipient waiting; so is
  the badge of a user of the receiving unit (badge_check: whose it is, to report as
  `opened_by`).

Usage::

    client = RobotClient(server_url="http://fleet:8000", robot="R3", token="...")
    client.on("plan", follow_plan)            # called once per new plan
    client.on("resource_grant", enter)        # once per grant
    client.update_state(status="idle", floor="15F", waypoint="15F-DOCK-3", battery=0.97)
    client.event("loaded", task="T-0042", stop=0)
    client.run(stop=threading.Event())        # heartbeat every interval, or at once on a wake
"""

import hashlib
import hmac
import json
import logging
import re
import threading
import uuid
from collections import OrderedDict
from collections.abc import Callable
from datetime import UTC, datetime

import requests

logger = logging.getLogger(__name__)

Handler = Callable[[dict], None]


def pin_check(pin: str, secure: dict) -> bool:
    """Whether `pin` opens a secure delivery, by its plan task's `secure` (protocol,
    "Secure deliveries"): PBKDF2-HMAC-SHA256 of the digits with the delivery's salt and
    iterations, compared in constant time. Needs no network."""
    return _opens(pin, secure["pin"])


def badge_check(badge: str, secure: dict) -> str | None:
    """The `holder` of the badge read at the robot if it opens a secure delivery, by its plan
    task's `secure.badges` (protocol, "Secure deliveries"), else None. Each entry is checked
    as a PIN is, with its own salt and iterations; no network needed."""
    for entry in secure.get("badges", ()):
        if _opens(badge, entry):
            return entry["holder"]
    return None


def _opens(secret: str, wire: dict) -> bool:
    """Whether a typed or read secret matches one hash as the plan carries it; an algorithm
    this client does not know never opens."""
    if wire.get("algorithm") != "pbkdf2_sha256":
        return False
    salt = bytes.fromhex(wire["salt"])
    tried = hashlib.pbkdf2_hmac("sha256", secret.encode(), salt, int(wire["iterations"]))
    return hmac.compare_digest(tried.hex(), wire["hash"])


class TransportError(Exception):
    """The heartbeat got no answer (connection refused or lost, timeout): keep everything."""


class RefusedError(Exception):
    """The server refused the heartbeat (4xx): nothing of it was applied.

    `body` is the server's answer; `sent` the heartbeat it refused. A 400 names the offending
    fields ("events[3].task", "requests[0].to_floor"): see RobotClient.drop_refused.
    """

    def __init__(self, status: int, body: dict | str, sent: dict | None = None):
        super().__init__(f"heartbeat refused with {status}: {body}")
        self.status = status
        self.body = body
        self.sent = sent or {}

    @property
    def fields(self) -> list[str]:
        detail = self.body.get("detail") if isinstance(self.body, dict) else None
        return list(detail) if isinstance(detail, dict) else []


class HttpTransport:
    """POSTs a JSON body; returns (status, parsed reply). Swap it to model a lossy network."""

    def __init__(self, *, timeout: float = 5.0):
        self.session = requests.Session()
        self.timeout = timeout

    def post(self, url: str, body: dict, headers: dict) -> tuple[int, dict | str]:
        try:
            response = self.session.post(url, json=body, headers=headers, timeout=self.timeout)
        except requests.RequestException as exc:
            raise TransportError(str(exc)) from exc
        try:
            return response.status_code, response.json()
        except ValueError:
            return response.status_code, response.text


def utc_now_iso() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


class RobotClient:
    SEEN_MESSAGES_KEPT = 2000

    def __init__(self, *, server_url: str, robot: str, token: str, transport=None, boot_id=None):
        self.url = f"{server_url.rstrip('/')}/api/v1/robots/{robot}/heartbeat"
        self.robot = robot
        self.headers = {"Authorization": f"Bearer {token}"}
        self.transport = transport or HttpTransport()
        self.boot_id = boot_id or str(uuid.uuid4())
        self.seq = 0
        self.heartbeat_interval = 1.0
        self.map_version: int | None = None  # as the server's answers name it
        self._map_handlers: list[Callable[[int], None]] = []
        self.plan_version = 0
        self.state: dict = {"status": "idle", "battery": 1.0, "load": 0, "errors": []}
        self._events: list[dict] = []
        self._acks: list[str] = []
        self._requests: list[dict] = []
        self._seen: OrderedDict[str, None] = OrderedDict()
        self._handlers: dict[str, list[Handler]] = {}
        self._event_numbers = iter(range(1, 2**62))
        self._lock = threading.RLock()  # one heartbeat in flight; state changes between them
        self.wake = threading.Event()
        # The push channel is open (listen_for_wakes): heartbeats say so, and while idle the
        # server may then tell a longer interval, since it wakes the robot for anything new.
        self.push_open = False
        # The wake's message id while its heartbeat is still to be sent: that heartbeat says so
        # (Woken-By), and the server answers it ahead of the queue of regular heartbeats.
        self.woken_by: str | None = None

    # --- What the robot tells the server -------------------------------------------------

    def update_state(self, **fields) -> None:
        with self._lock:
            self.state.update(fields)

    def event(self, type: str, **fields) -> str:
        """Queue an event (`arrived`, `loaded`, `resource_entered`, …); returns its id."""
        with self._lock:
            event_id = f"{self.boot_id[:8]}-{next(self._event_numbers)}"
            self._events.append({"id": event_id, "type": type, "at": utc_now_iso(), **fields})
            return event_id

    def acquire(self, resource: str, *, to_floor: str | None = None) -> str:
        """Ask for a shared resource; the answer comes as resource_grant / resource_queued."""
        request = {"type": "acquire", "resource": resource}
        if to_floor is not None:
            request["to_floor"] = to_floor
        return self._request(request)

    def release(self, resource: str) -> str:
        return self._request({"type": "release", "resource": resource})

    def _request(self, request: dict) -> str:
        with self._lock:
            request_id = f"q-{self.boot_id[:8]}-{next(self._event_numbers)}"
            self._requests.append({"id": request_id, **request})
            return request_id

    @property
    def unsent(self) -> int:
        """Events, acks and requests not yet known to have reached the server."""
        with self._lock:
            return len(self._events) + len(self._acks) + len(self._requests)

    def delivered(self, item_id: str) -> bool:
        """Whether the server has the event or request `item_id` (a heartbeat carrying it was
        answered). A robot about to lose the network, say boarding an elevator, waits for its
        `resource_entered` to be delivered first."""
        with self._lock:
            pending = (*self._events, *self._requests)
            return all(item["id"] != item_id for item in pending)

    def drop_refused(self, refused: RefusedError) -> list[dict]:
        """Drop the events and requests a 400 named ("events[3].task"); returns them.

        Resending them would be refused again, and with them every later heartbeat. Nothing
        else is dropped: a 400 about the state only is fixed by the next state.
        """
        named = {"events": set(), "requests": set()}
        for path in refused.fields:
            found = re.match(r"(events|requests)\[(\d+)\]", path)
            if found:
                items = refused.sent.get(found[1], [])
                index = int(found[2])
                if index < len(items):
                    named[found[1]].add(items[index]["id"])
        with self._lock:
            dropped = [e for e in self._events if e["id"] in named["events"]]
            dropped += [r for r in self._requests if r["id"] in named["requests"]]
            self._events = [e for e in self._events if e["id"] not in named["events"]]
            self._requests = [r for r in self._requests if r["id"] not in named["requests"]]
        for item in dropped:
            logger.error("%s: dropped %s refused by the server: %s", self.robot, item, refused)
        return dropped

    # --- What the server tells the robot -------------------------------------------------

    def on(self, message_type: str, handler: Handler) -> None:
        """Call handler(message) once for each new message of that type."""
        self._handlers.setdefault(message_type, []).append(handler)

    def woken(self, message_id: str | None) -> None:
        """A wake from the push channel (for `message_id`): heartbeat at once, saying so."""
        self.woken_by = message_id if isinstance(message_id, str) and message_id else None
        self.wake.set()

    def heartbeat(self) -> list[dict] | None:
        """Send one heartbeat. Returns the messages new to this robot, or None without answer.

        Raises RefusedError when the server refuses it (401/403/400/413): nothing of it was
        applied, and sending the same again would be refused again.
        """
        with self._lock:
            self.seq += 1
            body = self._body()
            headers, (woken, self.woken_by) = self.headers, (self.woken_by, None)
            if woken:
                headers = {**headers, "Woken-By": woken}
            try:
                status, reply = self.transport.post(self.url, body, headers)
            except TransportError as exc:
                logger.debug("%s: heartbeat %d unanswered: %s", self.robot, self.seq, exc)
                return None
            if status >= 500:
                logger.warning("%s: server error %d; will retry", self.robot, status)
                return None
            if status != 200:
                raise RefusedError(status, reply, body)
            self._answered(body)
            self.heartbeat_interval = float(reply.get("heartbeat_interval", 1.0))
            self._map_version_heard(reply.get("map_version"))
            return self._receive(reply.get("messages", []))

    def on_map_version(self, handler: Callable[[int], None]) -> None:
        """Call handler(version) whenever an answer names another map version than before."""
        self._map_handlers.append(handler)

    def _map_version_heard(self, version) -> None:
        """Before the messages of the same answer: a plan posted with a new map is routed on it
        (docs/robot-protocol.md, "Map versions")."""
        if not isinstance(version, int) or version == self.map_version:
            return
        self.map_version = version
        for handler in self._map_handlers:
            handler(version)

    def _body(self) -> dict:
        body = {
            "boot_id": self.boot_id,
            "seq": self.seq,
            "sent_at": utc_now_iso(),
            "state": {**self.state, "plan_version": self.plan_version},
            "events": list(self._events[:500]),
            "acks": list(self._acks),
            "requests": list(self._requests),
        }
        if self.push_open:
            body["push"] = True
        return body

    def _answered(self, body: dict) -> None:
        """The server has everything this heartbeat carried: stop resending it."""
        carried = {event["id"] for event in body["events"]}
        self._events = [event for event in self._events if event["id"] not in carried]
        self._acks = [ack for ack in self._acks if ack not in body["acks"]]
        sent = {request["id"] for request in body["requests"]}
        self._requests = [request for request in self._requests if request["id"] not in sent]

    def _receive(self, messages: list[dict]) -> list[dict]:
        new = []
        for message in messages:
            if message["id"] not in self._seen:
                self._apply(message)
                self._remember(message["id"])
                new.append(message)
            if message["id"] not in self._acks:
                self._acks.append(message["id"])  # ack again until the server stops sending it
        return new

    def _apply(self, message: dict) -> None:
        if message["type"] == "plan":
            if message["plan_version"] <= self.plan_version:
                return  # a late or repeated plan: harmless, only acked
            self.plan_version = message["plan_version"]
        for handler in self._handlers.get(message["type"], []):
            handler(message)

    def _remember(self, message_id: str) -> None:
        self._seen[message_id] = None
        while len(self._seen) > self.SEEN_MESSAGES_KEPT:
            self._seen.popitem(last=False)

    # --- The loop ------------------------------------------------------------------------

    def run(self, *, stop: threading.Event) -> None:
        """Heartbeat every interval, or at once when woken (push channel), until stop is set."""
        while not stop.is_set():
            try:
                self.heartbeat()
            except RefusedError as refused:
                logger.error("%s: heartbeat refused: %s", self.robot, refused)
                self.drop_refused(refused)
            self.wake.wait(timeout=self.heartbeat_interval)
            self.wake.clear()


def push_url(server_ws_url: str, robot: str) -> str:
    return f"{server_ws_url.rstrip('/')}/ws/robots/{robot}"


def listen_for_wakes(client: RobotClient, *, ws_url: str, token: str, stop: threading.Event):
    """The optional push channel: wake the client's loop whenever the server posts for it.

    Runs until stop is set, reconnecting after failures; losing it costs only latency. After
    every (re)connection the client is woken once: wakes sent while the socket was down are
    lost, and what they announced is on the board. While it is open the client's heartbeats
    say so (`push`); when it closes the client is woken at once, so that its next heartbeat,
    saying it no longer is, gets the interval of a robot without it.
    """
    from websockets.exceptions import WebSocketException
    from websockets.sync.client import connect

    headers = {"Authorization": f"Bearer {token}"}
    while not stop.is_set():
        try:
            with connect(push_url(ws_url, client.robot), additional_headers=headers) as socket:
                _wakes_relayed(client, socket, stop)
        except (OSError, WebSocketException) as exc:
            refused = getattr(getattr(exc, "rcvd", None), "code", None) in (4401, 4403)
            log = logger.warning if refused else logger.debug  # 4401/4403: a wrong token
            log("%s: push channel down (%s); reconnecting", client.robot, exc)
            stop.wait(timeout=2.0)


def _wakes_relayed(client: RobotClient, socket, stop: threading.Event) -> None:
    """Wake the client once, then for every wake frame, until the socket fails or stop is set;
    the client's heartbeats say the channel is open meanwhile."""
    client.push_open = True
    client.wake.set()
    try:
        while not stop.is_set():
            try:
                frame = socket.recv(timeout=1.0)
            except TimeoutError:
                continue
            wake = json.loads(frame)
            if wake.get("type") == "wake":
                client.woken(wake.get("message"))
    finally:
        client.push_open = False
        client.wake.set()  # its next heartbeat at once, without `push`
