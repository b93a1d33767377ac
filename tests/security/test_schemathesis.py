"""Schemathesis: requests generated from the OpenAPI schema (/api/schema/) for every
operation, sent over HTTP to the live server; none may give a 5xx, and every refusal comes
in the documented error shape. Bounded: a fixed number of examples per operation."""

import json

import pytest
import schemathesis
from drf_spectacular.generators import SchemaGenerator
from drf_spectacular.renderers import OpenApiJsonRenderer
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error

# The schema /api/schema/ serves (it needs a login, so it is generated here as that view does).
SCHEMA = json.loads(
    OpenApiJsonRenderer().render(SchemaGenerator().get_schema(request=None, public=True))
)
schema = schemathesis.openapi.from_dict(SCHEMA)


@pytest.fixture
def callers(live_server, staff, robot):
    """Headers per operation: the robot's token for its heartbeat, the staff token otherwise."""
    return {
        "robot": {"Authorization": f"Bearer {robot.token}"},
        "staff": {"Authorization": f"Bearer {staff.api_token_plain}"},
    }


@schema.parametrize()
@settings(
    max_examples=20,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
def test_no_generated_request_gives_a_5xx(case, live_server, callers):
    heartbeat = case.operation.path.endswith("/heartbeat")
    if heartbeat:
        case.path_parameters = {"robot": "R1"}

    response = case.call_and_validate(
        base_url=live_server.url,
        headers=callers["robot" if heartbeat else "staff"],
        checks=[not_a_server_error],
    )

    if response.status_code >= 400 and "json" in response.headers.get("Content-Type", [""])[0]:
        body = json.loads(response.content)
        assert set(body) == {"error", "detail"}, body
