"""The lift and door panels of the fleet page in Chromium: live as the car moves, and the
operator's out-of-service button with its confirmation."""

from datetime import timedelta

import pytest
from django.utils import timezone
from playwright.sync_api import expect

from building.models import Device
from building.services import devices_ensure, sim_step
from robots.models import Resource
from scheduling.models import OperatorAction
from tests.conftest import RobotHttp

pytestmark = pytest.mark.browser


@pytest.fixture
def robot_http(page_servers, robot):
    return RobotHttp(page_servers.http, robot)


def test_the_lift_panel_follows_the_car_and_takes_it_out_of_service(
    open_page, operator, site, robot_http
):
    devices_ensure(site=site)
    page = open_page(operator, "/fleet/?floor=2F")
    lift = page.locator('#resources tr[data-resource="ELEV"]')
    expect(lift.locator("[data-car-floor]")).to_have_text("1F")
    expect(lift.locator("[data-doors]")).to_have_text("closed")

    # R1 asks for the lift on 2F: granted, the car is called to it, live on the page.
    ride = {"id": "q-1", "type": "acquire", "resource": "ELEV", "to_floor": "3F"}
    state = {"floor": "2F", "waypoint": "2F-ELEV-WAIT"}
    robot_http.heartbeat(1, state=state, requests=[ride])
    expect(lift).to_contain_text("sent to 2F")
    sim_step(
        device=Device.objects.get(resource__code="ELEV"), now=timezone.now() + timedelta(minutes=1)
    )
    expect(lift.locator("[data-car-floor]")).to_have_text("2F")
    expect(lift.locator("[data-doors]")).to_have_text("open")

    # Out of service: asked first; dismissing changes nothing.
    lift.get_by_label("Reason for taking ELEV out of service").fill("doors sticking")
    button = lift.get_by_role("button", name="Take out of service ELEV")
    page.once("dialog", lambda dialog: dialog.dismiss())
    button.click()
    expect(lift.locator('[data-service="in"]')).to_be_visible()
    assert Resource.objects.get(site=site, code="ELEV").in_service

    messages = []
    page.once("dialog", lambda dialog: (messages.append(dialog.message), dialog.accept()))
    button.click()
    expect(lift.locator('[data-service="out"]')).to_have_text("Out of service")
    expect(lift).to_contain_text("doors sticking")
    assert "Take ELEV out of service?" in messages[0]
    assert not Resource.objects.get(site=site, code="ELEV").in_service
    assert OperatorAction.objects.get().by == operator
    expect(page.locator(".alerts, [data-part=alerts]").first).to_contain_text(
        "ELEV is out of service"
    )

    page.once("dialog", lambda dialog: dialog.accept())
    lift.get_by_role("button", name="Return to service ELEV").click()
    expect(lift.locator('[data-service="in"]')).to_be_visible()
