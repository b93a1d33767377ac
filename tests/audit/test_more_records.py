"""The kinds of action test_events.py leaves out, each through its real interface: a map
published and rolled back in the map editor's API, a site membership given in the admin, an API
token issued by the management command, a fire alarm and its all-clear from a building system,
a robot taken into maintenance and returned."""

import copy

from django.core.management import call_command
from django.test import Client

from audit.choices import Kind
from hospital_delivery.models import ApiToken
from robots.models import SiteMembership
from tests import factories
from tests.audit.conftest import entries, logged_in, newest_id
from tests.maps.test_api import DRAFT, draft, post, put
from tests.scheduling.test_fire_alarm_api import URL


def test_it_records_a_map_published_and_rolled_back(site, staff):
    client = logged_in(staff)
    document = copy.deepcopy(draft(client)["document"])
    document["name"] = "Renamed hospital"
    revision = put(client, {"revision": 1, "document": document}).json()["revision"]
    before = newest_id()

    published = post(client, f"{DRAFT}/publish", {"revision": revision, "note": "rename"})
    restored = post(client, "/api/v1/maps/tiny/versions/1/restore", {})

    assert (published.status_code, restored.status_code) == (201, 201)
    first, second = entries(Kind.MAP_PUBLISHED, id__gt=before)
    assert (first.actor, first.site_id) == (staff, site.pk)
    assert first.changes["map_version"] == [1, 2]
    assert second.actor == staff
    assert second.changes["map_version"][0] == 2
    assert second.additional_data["restored_from"] == 1


def test_it_records_a_site_membership_given_in_the_admin(site):
    root = factories.staff_create("root", is_superuser=True)
    newcomer = factories.user_create("lee", "nurse", sites=[])
    before = newest_id()

    response = logged_in(root).post(
        "/admin/robots/sitemembership/add/",
        {"user": newcomer.pk, "site": site.pk, "unit": "", "badge": ""},
    )

    assert response.status_code == 302, response.context["errors"]
    membership = SiteMembership.objects.get(user=newcomer)
    [created] = entries(Kind.CHANGE, id__gt=before, object_pk=str(membership.pk))
    assert created.actor == root
    assert created.content_type.model == "sitemembership"


def test_it_records_an_api_token_issued_by_the_management_command(db):
    holder = factories.staff_create("systems")
    before = newest_id()

    call_command("user_token", "systems", stdout=open("/dev/null", "w"))  # noqa: SIM115

    token = ApiToken.objects.filter(user=holder).order_by("pk").last()
    recorded = entries(Kind.CHANGE, id__gt=before, content_type__model="apitoken")
    assert [entry.object_pk for entry in recorded][-1] == str(token.pk)
    assert "(secret)" in str(recorded[-1].changes)


def test_it_records_a_fire_alarm_and_its_all_clear_from_a_building_system(site):
    building = factories.user_create("bms", "operator")
    api = Client(HTTP_AUTHORIZATION=f"Bearer {ApiToken.issue(building)}")
    before = newest_id()

    started = api.post(URL, {"floors": ["1F"]}, content_type="application/json")
    ended = api.post(f"{URL}/all-clear", {}, content_type="application/json")

    assert (started.status_code, ended.status_code) == (201, 200), ended.content
    alarm, all_clear = entries(Kind.OPERATOR_ACTION, id__gt=before, content_type__model="emergency")
    assert (alarm.actor, alarm.site_id) == (building, site.pk)
    assert alarm.additional_data == {"action": "fire_alarm", "via": "api", "floors": ["1F"]}
    assert (all_clear.actor, all_clear.additional_data["action"]) == (building, "all_clear")


def test_it_records_a_robot_taken_into_maintenance_and_returned(site, staff):
    robot = factories.robot_create(site, "R1")
    client = logged_in(staff)
    before = newest_id()

    taken = client.post(
        f"/api/v1/robots/{robot.code}/maintenance",
        {"reason": "sensor cleaning"},
        content_type="application/json",
    )
    back = client.post(
        f"/api/v1/robots/{robot.code}/return-to-service", {}, content_type="application/json"
    )

    assert taken.status_code < 300, taken.content
    assert back.status_code < 300, back.content
    recorded = entries(Kind.OPERATOR_ACTION, id__gt=before, object_pk=str(robot.pk))
    assert [(e.actor, e.additional_data["action"]) for e in recorded] == [
        (staff, "maintenance"),
        (staff, "maintenance_end"),
    ]
