"""Hospital sign-in in Chromium, against a real directory (slapd) and a real single sign-on
provider (oidc-provider) started for this module, and gunicorn configured for both from the
environment as a deployment is: a directory nurse orders, a single sign-on operator sees only
her site's fleet and signs out of the provider too, groups and disabled accounts count at the
next sign-in, wrong passwords are throttled, and two nurses order at a shared workstation."""

import re
from types import SimpleNamespace

import pytest
from playwright.sync_api import expect

from accounts.models import Workstation
from accounts.services import account_pin_set
from robots.models import SiteMembership
from robots.services import membership_badge_set
from scheduling.models import Task
from tests import factories, servers, signin
from tests.browser.conftest import DESKTOP
from tests.directory import PASSWORD, Directory
from tests.oidc_provider import PASSWORD as PROVIDER_PASSWORD
from tests.oidc_provider import Provider

pytestmark = pytest.mark.browser
PHONE = {"width": 390, "height": 844}


@pytest.fixture(scope="module")
def signin_servers(django_db_setup, django_db_blocker):
    port = servers.free_port()
    url = f"http://127.0.0.1:{port}"
    with (
        Directory(signin.DIRECTORY_PEOPLE) as directory,
        Provider(signin.PROVIDER_ACCOUNTS, server_urls=[url]) as provider,
        servers.celery_sink("signin") as queue,
    ):
        env = {
            **directory.env(),
            **provider.env(),
            "ROLE_GROUPS": signin.ROLE_GROUPS,
            "SITE_GROUPS": signin.SITE_GROUPS,
            "CELERY_QUEUE": queue,
        }
        with servers.gunicorn(workers=2, env=env, port=port) as http:
            yield SimpleNamespace(http=http, directory=directory, provider=provider)


@pytest.fixture
def sites(transactional_db):
    tiny = factories.site_create(members=[])
    other = factories.site_create(members=[], site="other", name="Other hospital")
    factories.robot_create(tiny, "T-1")
    factories.robot_create(other, "O-1")
    return tiny, other


@pytest.fixture
def browse(chromium, signin_servers, sites):
    def open_(path: str, *, viewport=DESKTOP):
        context = chromium.new_context(viewport=viewport, base_url=signin_servers.http)
        page = context.new_page()
        page.goto(path)
        return page

    return open_


def sign_in(page, username: str, password: str = PASSWORD) -> None:
    page.get_by_label("Username").fill(username)
    page.get_by_label("Password").fill(password)
    page.get_by_role("button", name="Log in").click()


def test_a_directory_nurse_signs_in_and_orders(browse):
    page = browse("/")
    sign_in(page, "yoon")

    expect(page.locator(".account-name")).to_contain_text("Yoon Seo")
    expect(page.locator(".account-name .role")).to_have_text("nurse")
    page.get_by_label("Sender").fill("Ward 3")
    page.get_by_label("Receiver").fill("Laboratory reception")
    page.get_by_label("Contents").fill("Blood samples")
    page.get_by_label("Pick-up").fill("Ward 3")
    page.get_by_label("Drop-off").fill("Laboratory")
    page.get_by_role("button", name="Request delivery").click()

    expect(page.locator(".messages")).to_contain_text("requested: Blood samples.")
    assert Task.objects.get().requester.username == "yoon"


def test_a_single_sign_on_operator_sees_her_site_and_signs_out_of_the_provider(browse):
    page = browse("/fleet/")
    page.get_by_role("link", name="Sign in with Test ID").click()
    expect(page.get_by_role("heading", name="Sign in to the test provider")).to_be_visible()
    page.get_by_label("User name").fill("song")
    page.get_by_label("Password").fill(PROVIDER_PASSWORD)
    page.get_by_role("button", name="Sign in").click()

    expect(page).to_have_url(re.compile(r"/fleet/$"))
    expect(page.locator(".account-name .role")).to_have_text("operator")
    expect(page.locator(".site-name")).to_have_text("Other hospital")
    expect(page.get_by_role("link", name="O-1", exact=True).first).to_be_visible()
    expect(page.get_by_text("T-1", exact=True)).to_have_count(0)

    page.get_by_role("button", name="Log out").click()
    page.get_by_role("button", name="Yes, sign me out").click()
    expect(page).to_have_url(re.compile(r"/accounts/login/$"))
    page.get_by_role("link", name="Sign in with Test ID").click()
    # The provider's session ended: it asks who is signing in again.
    expect(page.get_by_role("heading", name="Sign in to the test provider")).to_be_visible()


def test_a_nurse_removed_from_the_group_loses_the_role_at_the_next_sign_in(browse, signin_servers):
    page = browse("/")
    sign_in(page, "han")
    expect(page.locator(".account-name .role")).to_have_text("nurse")
    page.get_by_role("button", name="Log out").click()

    signin_servers.directory.group_remove("ward-nurses", "han")
    sign_in(page, "han")

    expect(page.get_by_role("heading", name="Not allowed")).to_be_visible()
    expect(page.get_by_text("neither the nurse nor the operator group")).to_be_visible()


def test_wrong_directory_passwords_are_throttled_as_for_local_users(browse):
    page = browse("/")
    for _ in range(5):  # LOGIN_FAILURE_LIMIT's default
        sign_in(page, "jang", "not-her-password")
    expect(page.get_by_role("heading", name="Login locked")).to_be_visible()

    page.goto("/accounts/login/")
    sign_in(page, "jang")  # her password, too late

    expect(page.get_by_role("heading", name="Login locked")).to_be_visible()


def test_a_disabled_directory_account_cannot_sign_in(browse, signin_servers):
    signin_servers.directory.disable("baek")
    page = browse("/")

    sign_in(page, "baek")

    expect(page.get_by_role("alert")).to_contain_text("Please enter a correct username")
    expect(page).to_have_url(re.compile(r"/accounts/login/"))


@pytest.fixture
def ward_desk(sites):
    """Two nurses of Ward 3 with badges and PINs, and the ward's workstation account."""
    tiny = sites[0]
    for username, first, last, badge, pin in [
        ("kim", "Jiwoo", "Kim", "04A1-7731-0093", "4821"),
        ("lee", "Sora", "Lee", "04A1-7731-0117", "7305"),
    ]:
        nurse = factories.user_create(
            username, "nurse", sites=[tiny], first_name=first, last_name=last
        )
        membership_badge_set(membership=SiteMembership.objects.get(user=nurse), badge=badge)
        account_pin_set(user=nurse, pin=pin)
    account = factories.user_create("ws-ward3", sites=[])
    unit = tiny.waypoints.get(code="3F-WARD")
    Workstation.objects.create(user=account, site=tiny, unit=unit, name="Ward 3 desk")


def order_at_desk(page, contents: str, badge: str, pin: str) -> None:
    page.get_by_label("Sender").fill("Ward 3")
    page.get_by_label("Receiver").fill("Laboratory reception")
    page.get_by_label("Contents").fill(contents)
    page.get_by_label("Pick-up").fill("Ward 3")
    page.get_by_label("Drop-off").fill("Laboratory")
    page.get_by_label("Badge").fill(badge)
    page.get_by_label("Badge").press("Enter")  # as a badge reader ends its number
    expect(page.get_by_label("PIN", exact=True)).to_be_focused()
    page.get_by_label("PIN", exact=True).fill(pin)
    page.get_by_role("button", name="Confirm and request").click()


def test_two_nurses_order_at_a_shared_workstation_by_badge_and_pin(browse, ward_desk):
    page = browse("/")
    sign_in(page, "ws-ward3", factories.PASSWORD)
    expect(page).to_have_url(re.compile(r"/workstation/$"))

    order_at_desk(page, "Blood samples", "04A1-7731-0093", "4821")
    expect(page.locator(".messages")).to_contain_text("requested by Jiwoo Kim: Blood samples.")
    order_at_desk(page, "Medication", "04A1-7731-0117", "7305")
    expect(page.locator(".messages")).to_contain_text("requested by Sora Lee: Medication.")

    orders = page.locator("#workstation-orders tbody tr")
    expect(orders.filter(has_text="Medication")).to_contain_text("Sora Lee")
    expect(orders.filter(has_text="Blood samples")).to_contain_text("Jiwoo Kim")
    assert [t.requester.username for t in Task.objects.order_by("pk")] == ["kim", "lee"]

    order_at_desk(page, "Linen", "04A1-7731-0093", "1357")
    expect(page.get_by_text("This badge and PIN do not match")).to_be_visible()
    for _ in range(4):
        order_at_desk(page, "Linen", "04A1-7731-0093", "1357")
    expect(page.get_by_role("heading", name="Ordering locked")).to_be_visible()
    page.get_by_role("link", name="Back to the workstation").click()
    expect(page.get_by_role("heading", name="Request a delivery")).to_be_visible()
    assert Task.objects.count() == 2


def test_the_login_and_workstation_pages_fit_a_phone(browse, ward_desk):
    page = browse("/accounts/login/", viewport=PHONE)
    expect(page.get_by_role("link", name="Sign in with Test ID")).to_be_visible()
    assert page.evaluate("document.documentElement.scrollWidth") <= PHONE["width"]

    sign_in(page, "ws-ward3", factories.PASSWORD)
    expect(page.get_by_role("heading", name="Request a delivery")).to_be_visible()
    assert page.evaluate("document.documentElement.scrollWidth") <= PHONE["width"]
