"""Each person sees their own role and only the links they may use: an operator has no map
editor or admin, an administrator wears "administrator", and the admin spells its plurals."""

from django.contrib import admin

from tests.ui.conftest import logged_in
from webhooks.models import WebhookDelivery


def test_it_shows_an_operator_no_link_they_may_not_use(operator_client, site):
    html = operator_client.get(f"/fleet/?site={site.code}").content.decode()
    assert '<span class="role">operator</span>' in html
    assert "Map editor" not in html
    assert ">Admin<" not in html


def test_it_calls_an_administrator_an_administrator(staff, site):
    html = logged_in(staff).get(f"/fleet/?site={site.code}").content.decode()
    assert '<span class="role">administrator</span>' in html
    assert '<span class="role">operator</span>' not in html
    assert "Map editor" in html


def test_it_names_webhook_deliveries_in_the_admin():
    assert admin.site.is_registered(WebhookDelivery)
    assert str(WebhookDelivery._meta.verbose_name_plural) == "webhook deliveries"
