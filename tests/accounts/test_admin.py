"""The admin shows where each user comes from and sets a person's workstation PIN."""

from django.test import Client

from accounts.choices import Source
from accounts.models import Account
from tests import factories


def test_the_users_list_shows_where_each_comes_from(db):
    admin = factories.staff_create("root", is_superuser=True)
    directory_user = factories.user_create("yoon", "nurse")
    Account.objects.create(user=directory_user, source=Source.LDAP, subject="uid=yoon,ou=people")
    client = Client()
    client.force_login(admin)

    page = client.get("/admin/auth/user/?account__source__exact=ldap").content.decode()
    listing = client.get("/admin/auth/user/").content.decode()

    assert "yoon" in page
    assert "root" not in page.split('id="result_list"')[1]
    assert "LDAP directory" in listing
    assert 'class="field-source">local<' in listing


def test_an_administrator_sets_a_pin_of_which_only_the_hash_is_kept(db):
    admin = factories.staff_create("root", is_superuser=True)
    nurse = factories.user_create("kim", "nurse")
    client = Client()
    client.force_login(admin)
    page = client.get(f"/admin/auth/user/{nurse.pk}/change/").content.decode()
    assert "New workstation PIN" in page

    form = {
        "username": "kim",
        "date_joined_0": "2026-01-01",
        "date_joined_1": "08:00:00",
        "account-TOTAL_FORMS": "1",
        "account-INITIAL_FORMS": "0",
        "account-MIN_NUM_FORMS": "0",
        "account-MAX_NUM_FORMS": "1",
        "account-0-user": str(nurse.pk),
        "account-0-pin": "26031",
    }
    response = client.post(f"/admin/auth/user/{nurse.pk}/change/", form)

    assert response.status_code == 302, response.content.decode()[-3000:]
    account = Account.objects.get(user=nurse)
    assert account.pin_matches("26031")
    assert account.source == Source.LOCAL
