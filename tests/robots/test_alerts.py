from robots.alerts import alert_acknowledge, alert_raise
from robots.models import Alert


def raise_alert(site, key="lease:L-1"):
    return alert_raise(site_id=site.pk, kind="lease_hard_limit", key=key, message="stuck")


def test_it_raises_one_open_alert_per_key(site, django_capture_on_commit_callbacks):
    with django_capture_on_commit_callbacks() as pushes:
        first = raise_alert(site)
        again = raise_alert(site)

    assert first.pk == again.pk
    assert Alert.objects.count() == 1
    # One live push to the pages (the activity log's line is written after commit too).
    assert [push.__qualname__ for push in pushes].count("publish_on_commit.<locals>.<lambda>") == 1


def test_it_raises_again_after_acknowledgement(site, staff):
    first = raise_alert(site)

    assert alert_acknowledge(alert=first, user=staff) is True
    assert alert_acknowledge(alert=first, user=staff) is False
    second = raise_alert(site)

    assert second.pk != first.pk
    assert list(Alert.objects.open()) == [second]
