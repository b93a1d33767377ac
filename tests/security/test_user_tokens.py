"""API tokens of users: listed and revoked (command and admin); a revoked token stops working."""

import io
import re

import requests
from django.core.management import call_command

from hospital_delivery.models import ApiToken
from tests import factories
from tests.security.conftest import logged_in_session


def command(*args) -> str:
    out = io.StringIO()
    call_command("user_token", *args, stdout=out)
    return out.getvalue()


def api_status(base_url: str, token: str) -> int:
    headers = {"Authorization": f"Bearer {token}"}
    return requests.get(f"{base_url}/api/v1/robots/", headers=headers, timeout=30).status_code


def test_the_command_lists_token_holders_without_their_tokens(db):
    staff = factories.staff_create("hisbridge")

    listing = command("--list")

    assert "hisbridge" in listing
    assert staff.api_token_plain not in listing


def test_a_token_revoked_with_the_command_stops_working(live_server, staff):
    assert api_status(live_server.url, staff.api_token_plain) == 200

    assert "revoked" in command(staff.username, "--revoke")

    assert api_status(live_server.url, staff.api_token_plain) == 401
    assert not ApiToken.objects.filter(user=staff).exists()


def test_an_administrator_revokes_a_token_in_the_admin(live_server, staff):
    holder = factories.staff_create("hisbridge")
    staff.is_superuser = True
    staff.save(update_fields=["is_superuser"])
    admin = logged_in_session(staff)
    url = f"{live_server.url}/admin/hospital_delivery/apitoken/{holder.api_token.pk}/delete/"

    page = admin.get(url, timeout=30)
    token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page.text).group(1)
    admin.post(
        url,
        data={"post": "yes", "csrfmiddlewaretoken": token},
        headers={"Referer": live_server.url},
        timeout=30,
    )

    assert api_status(live_server.url, holder.api_token_plain) == 401
