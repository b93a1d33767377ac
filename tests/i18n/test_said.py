"""Alerts and a delivery's history in each reader's language: the words are kept as their
English msgid and values, and rendered when shown; the English text stays for the API, webhooks
and logs."""

from django.utils import translation
from django.utils.translation import gettext_noop

from core.said import Said
from resources.availability import resource_take_out_of_service
from robots.models import Alert, Resource
from scheduling.services import robot_action, task_allocate
from tests import factories
from tests.scheduling.conftest import request as order_task
from tests.scheduling.conftest import robot_ready
from tests.ui.conftest import logged_in


def test_said_words_come_back_from_json_and_speak_each_language():
    said = Said(
        gettext_noop("%(robot)s went offline carrying %(codes)s"),
        robot="R1",
        codes=Said(gettext_noop("given to another robot")),
    )

    again = Said.from_json(said.as_json())

    assert again == said
    assert len({again, said}) == 1  # outcomes of one refusal are gathered in a set
    assert again.in_english() == "R1 went offline carrying given to another robot"
    with translation.override("ko"):
        assert str(again) == "R1이(가) 다른 로봇에게 넘김을(를) 싣고 오프라인이 됨"


def test_an_alert_reads_korean_on_a_korean_page_and_english_in_its_message(site, operator):
    lift = Resource.objects.get(site=site, code="ELEV")

    resource_take_out_of_service(resource=lift, reason="점검", actor=operator)

    alert = Alert.objects.get()
    assert alert.message.startswith("ELEV is out of service by park: 점검. Robots go another way")
    page = logged_in(operator).get("/fleet/", HTTP_ACCEPT_LANGUAGE="ko").content.decode()
    assert "park 님이 ELEV 사용을 중지함: 점검." in page
    assert "is out of service" not in page


def test_a_nurse_reads_why_her_delivery_was_given_back_in_her_language(site, nurse, operator):
    robot = factories.robot_create(site, "R1")
    robot_ready(robot)
    task = order_task(site, user=nurse)
    assert task_allocate(task_id=task.pk)

    robot_action(robot=robot, action="return_to_dock", by=operator)

    task.refresh_from_db()
    entry = task.history.order_by("at", "id").last()
    assert entry.note == "R1 recalled to its dock by an operator"
    page = logged_in(nurse).get("/", HTTP_ACCEPT_LANGUAGE="ko").content.decode()
    assert "운영자가 R1을(를) 도크로 불러들임: 다른 로봇을 기다리는 중" in page
