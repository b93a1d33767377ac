"""A small HTTP server standing for another hospital system: it records every webhook request
and answers 500 to the first `fail_first` of them."""

import json
import threading
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

from webhooks.signing import EVENT_ID_HEADER, SIGNATURE_HEADER, TIMESTAMP_HEADER, signature_valid


@dataclass
class Received:
    event_id: str
    timestamp: str
    signed: str
    body: bytes
    answered: int
    content_type: str = ""

    @property
    def payload(self) -> dict:
        return json.loads(self.body)

    def signed_with(self, secret: str) -> bool:
        return signature_valid(secret, timestamp=self.timestamp, body=self.body, signed=self.signed)


class HookReceiver:
    def __init__(self, *, fail_first: int = 0):
        self.fail_first = fail_first
        self.received: list[Received] = []
        self._lock = threading.Lock()
        receiver = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self):  # noqa: N802 (http.server's name)
                body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
                with receiver._lock:
                    answer = 500 if len(receiver.received) < receiver.fail_first else 200
                    receiver.received.append(
                        Received(
                            event_id=self.headers.get(EVENT_ID_HEADER, ""),
                            timestamp=self.headers.get(TIMESTAMP_HEADER, ""),
                            signed=self.headers.get(SIGNATURE_HEADER, ""),
                            body=body,
                            answered=answer,
                            content_type=self.headers.get("Content-Type", ""),
                        )
                    )
                self.send_response(answer)
                self.send_header("Content-Type", "text/plain")
                self.end_headers()
                self.wfile.write(b"ok" if answer == 200 else b"busy, try later")

            def log_message(self, *args):
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/hook"

    def __enter__(self):
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        return self

    def __exit__(self, *exc):
        self.server.shutdown()
        self.server.server_close()

    def accepted(self) -> list[Received]:
        with self._lock:
            return [each for each in self.received if each.answered == 200]

    def refused(self) -> list[Received]:
        with self._lock:
            return [each for each in self.received if each.answered != 200]
