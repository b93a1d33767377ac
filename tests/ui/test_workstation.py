"""A shared ward workstation: signed in as itself, each order confirmed by the person placing it
(badge and PIN, or user name and password) and placed in that person's name; wrong PINs
throttled as wrong passwords are; badge and PIN never shown nor kept in clear."""

import pytest
from axes.models import AccessAttempt
from django.conf import settings
from django.contrib.auth import get_user_model
from django.contrib.auth.signals import user_login_failed
from django.test import Client

from accounts.models import Workstation
from accounts.services import account_pin_set
from robots.models import SiteMembership
from robots.services import membership_badge_set
from scheduling.models import Task
from tests import factories

User = get_user_model()
BADGES = {"kim": "04A1-7731-0093", "lee": "04A1-7731-0117"}
PINS = {"kim": "4821", "lee": "7305"}


def badge_and_pin(user, badge: str, pin: str) -> None:
    membership = SiteMembership.objects.get(user=user)
    membership_badge_set(membership=membership, badge=badge)
    account_pin_set(user=user, pin=pin)


@pytest.fixture
def nurses(db, site):
    kim = factories.user_create("kim", "nurse", first_name="Jiwoo", last_name="Kim")
    lee = factories.user_create("lee", "nurse", first_name="Sora", last_name="Lee")
    for nurse in (kim, lee):
        badge_and_pin(nurse, BADGES[nurse.username], PINS[nurse.username])
    return kim, lee


@pytest.fixture
def desk(site, nurses):
    """The Ward 3 workstation's browser, signed in as the workstation."""
    account = User.objects.create_user("ws-ward3", password=factories.PASSWORD)
    unit = site.waypoints.get(code="3F-WARD")
    Workstation.objects.create(user=account, site=site, unit=unit, name="Ward 3 desk")
    client = Client()
    client.force_login(account)
    return client


def order(client, **identity):
    data = {
        "sender": "Ward 3",
        "receiver": "Laboratory reception",
        "contents": "Blood samples",
        "pickup": ["Ward 3"],
        "dropoff": ["Laboratory"],
        "priority": "routine",
        "repeat": "",
        **identity,
    }
    return client.post("/workstation/", data)


def by_badge(name: str, pin: str | None = None) -> dict:
    return {"badge": BADGES[name], "pin": PINS[name] if pin is None else pin}


def test_two_nurses_order_one_after_the_other_each_in_her_name(desk, nurses):
    kim, lee = nurses

    first = order(desk, **by_badge("kim"))
    second = order(desk, **by_badge("lee"), contents="Medication")

    assert first.status_code == second.status_code == 302
    assert first["Location"] == "/workstation/"
    tasks = list(Task.objects.order_by("pk"))
    assert [(t.contents, t.requester) for t in tasks] == [
        ("Blood samples", kim),
        ("Medication", lee),
    ]
    assert desk.session["_auth_user_id"] == str(User.objects.get(username="ws-ward3").pk)
    page = desk.get("/workstation/").content.decode()
    assert f"Delivery {tasks[1].code} requested by Sora Lee: Medication." in page
    rows = page.split('id="workstation-orders"')[1]
    assert rows.index("Sora Lee") < rows.index("Jiwoo Kim")  # newest first, each with her name


def test_a_wrong_pin_orders_nothing_and_the_secrets_are_not_sent_back(desk, nurses):
    with_signal = []
    user_login_failed.connect(record := lambda **kw: with_signal.append(kw), weak=False)
    try:
        response = order(desk, **by_badge("kim", pin="9999"))
    finally:
        user_login_failed.disconnect(record)

    assert response.status_code == 400
    html = response.content.decode()
    assert "This badge and PIN do not match" in html
    assert 'value="Blood samples"' in html  # the order is kept for the next try
    assert BADGES["kim"] not in html
    assert "9999" not in html
    assert not Task.objects.exists()
    assert with_signal[0]["credentials"]["pin_secret"] != "9999"  # masked by Django
    attempt = AccessAttempt.objects.get(username="kim")
    assert BADGES["kim"] not in attempt.post_data
    assert "9999" not in attempt.post_data


def test_wrong_pins_are_throttled_like_wrong_passwords(desk, nurses):
    for _ in range(settings.AXES_FAILURE_LIMIT):
        order(desk, **by_badge("kim", pin="1357"))

    locked = order(desk, **by_badge("kim"))  # the right PIN, too late

    assert locked.status_code == 429
    assert "Ordering locked" in locked.content.decode()
    assert "kim" not in locked.content.decode()  # a found badge does not tell whose it is
    assert not Task.objects.exists()
    assert order(desk, **by_badge("lee")).status_code == 302  # others still order here


def test_too_many_failures_from_one_address_lock_the_workstation_before_any_hash(
    desk, nurses, settings
):
    settings.LOGIN_ADDRESS_FAILURE_LIMIT = 2
    order(desk, **by_badge("kim", pin="1357"))
    order(desk, badge="0000-0000-0001", pin="2468")

    locked = order(desk, **by_badge("lee"))  # right, but from an address out of allowance

    assert locked.status_code == 429
    assert "ordering here is locked" in locked.content.decode()
    assert not Task.objects.exists()


def test_unknown_badges_are_throttled_at_the_workstation(desk, nurses):
    for _ in range(settings.AXES_FAILURE_LIMIT):
        order(desk, badge="0000-0000-0001", pin="2468")

    attempt = AccessAttempt.objects.get()
    assert attempt.username == "unknown badge at ws-ward3"
    assert order(desk, badge="0000-0000-0002", pin="2468").status_code == 429


def test_a_right_pin_forgives_the_earlier_mistakes(desk, nurses):
    for _ in range(settings.AXES_FAILURE_LIMIT - 1):
        order(desk, **by_badge("kim", pin="1357"))
    assert order(desk, **by_badge("kim")).status_code == 302

    assert order(desk, **by_badge("kim", pin="1357")).status_code == 400  # not locked out


def test_a_person_without_her_badge_confirms_with_her_password(desk, nurses):
    response = order(desk, username="kim", password=factories.PASSWORD)

    assert response.status_code == 302
    assert Task.objects.get().requester == nurses[0]


@pytest.mark.parametrize(
    ("identity", "field", "error"),
    [
        ({}, "badge", "Scan your badge and type your PIN"),
        ({"badge": BADGES["kim"]}, "pin", "Type your PIN after scanning"),
        ({"username": "kim"}, "password", "Type your password as well"),
    ],
)
def test_it_says_what_is_missing(desk, nurses, identity, field, error):
    response = order(desk, **identity)

    assert response.status_code == 400
    html = response.content.decode()
    assert f'id="id_{field}_error">{error}' in html
    assert not Task.objects.exists()
    assert not AccessAttempt.objects.exists()  # nothing was tried


def test_an_order_that_cannot_be_placed_tries_no_identification(desk, nurses):
    response = order(desk, **by_badge("kim", pin="1357"), dropoff=["Nowhere"])

    assert response.status_code == 400
    assert not AccessAttempt.objects.exists()


def test_someone_of_another_site_may_not_order_here(desk, nurses, site):
    other = factories.site_create(members=[], site="other", name="Other hospital")
    stranger = factories.user_create("oh", "nurse", sites=[other])
    SiteMembership.objects.filter(user=stranger).update(site=other)
    account_pin_set(user=stranger, pin="5820")

    response = order(desk, username="oh", password=factories.PASSWORD)

    assert response.status_code == 400
    assert "may not order deliveries at Tiny test hospital" in response.content.decode()
    assert not Task.objects.exists()


def test_a_workstation_is_sent_to_its_page_and_orders_nothing_itself(desk):
    assert desk.get("/")["Location"] == "/workstation/"
    assert desk.get("/fleet/").status_code == 403
    assert order(desk, username="ws-ward3", password=factories.PASSWORD).status_code == 400


def test_only_a_workstation_has_the_workstation_page(nurses):
    client = Client()
    client.force_login(nurses[0])

    assert client.get("/workstation/").status_code == 403


def test_a_nurse_sets_her_own_pin(nurses):
    kim = nurses[0]
    client = Client()
    client.force_login(kim)

    easy = client.post("/account/pin/", {"pin": "1234", "pin_again": "1234"})
    set_ = client.post("/account/pin/", {"pin": "50817", "pin_again": "50817"})

    assert easy.status_code == 400
    assert "too easy to guess" in easy.content.decode()
    assert set_.status_code == 302
    kim.account.refresh_from_db()
    assert kim.account.pin_matches("50817")
    assert "50817" not in kim.account.pin_hash
