"""The server in this very process: Django's test client as the transport of simulated robots
(RobotClient) and of the request generator, so a whole fleet can run deterministically on a
virtual clock (bench/fleet_day.py, tests). Every request still goes through the full HTTP stack
of the project (middleware, authentication, serializers, views); only the socket is missing.
"""

import json
from urllib.parse import urlsplit

from django.test import Client

SERVER_URL = "http://localhost"  # what in-process robots and users are given as the server


def test_client() -> Client:
    # "localhost" is in the default ALLOWED_HOSTS; server errors raise here, loudly.
    return Client(HTTP_HOST="localhost", raise_request_exception=True)


def _reply(response) -> dict | str:
    try:
        return response.json()
    except ValueError:
        return response.content.decode("utf-8", "replace")


class InProcessTransport:
    """A RobotClient transport that posts through django.test.Client."""

    def __init__(self, client: Client | None = None):
        self.client = client or test_client()

    def post(self, url: str, body: dict, headers: dict) -> tuple[int, dict | str]:
        response = self.client.post(
            urlsplit(url).path,
            data=json.dumps(body),
            content_type="application/json",
            headers=headers,
        )
        return response.status_code, _reply(response)

    def close(self) -> None:
        pass


class InProcessTaskApi:
    """The task API (POST /api/v1/tasks/) through django.test.Client, with a user's token."""

    def __init__(self, token: str, client: Client | None = None):
        self.client = client or test_client()
        self.headers = {"Authorization": f"Bearer {token}"}

    def post(self, body: dict) -> tuple[int, dict]:
        response = self.client.post(
            "/api/v1/tasks/",
            data=json.dumps(body),
            content_type="application/json",
            headers=self.headers,
        )
        return response.status_code, _reply(response)
