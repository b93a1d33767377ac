"""More kinds of action through their real interfaces: a resource taken out of service on its
page."""

import pytest

from audit.choices import Kind
from tests.audit.conftest import logged_in, only_entry

pytestmark = pytest.mark.django_db


def test_it_records_a_resource_taken_out_of_service_on_its_page(operator, site):
    logged_in(operator).post(
        "/resources/tiny/ELEV/service", {"in_service": "false", "reason": "stuck doors"}
    )

    action = only_entry(Kind.OPERATOR_ACTION)
    assert (action.actor, action.object_repr) == (operator, "Take out of service: ELEV")
    assert action.additional_data == {"action": "out_of_service", "note": "stuck doors"}
