"""In Chromium: a browser set to Korean gets the pages in Korean, the language menu switches them
(at a phone's width too), before and after a nurse signs in, and her choice is kept with her.
A Korean nurse orders a delivery and follows it to its end in Korean while an operator's page
shows the same steps in English at the same moments."""

import copy

from django.utils import translation
from playwright.sync_api import expect

from accounts.models import Account
from scheduling.choices import TaskStatus
from scheduling.models import Task
from tests import factories
from tests.conftest import RobotHttp
from tests.scheduling.conftest import event

PHONE = {"width": 390, "height": 844}


def test_a_korean_browser_reads_korean_and_the_menu_switches_to_italian(
    chromium, page_servers, site, nurse
):
    context = chromium.new_context(locale="ko-KR", viewport=PHONE, base_url=page_servers.http)
    page = context.new_page()
    page.goto("/accounts/login/")
    expect(page.locator("html")).to_have_attribute("lang", "ko")
    expect(page.get_by_role("heading", level=1)).to_have_text("로그인")
    assert page.evaluate("document.documentElement.scrollWidth <= window.innerWidth")

    page.get_by_label("언어").select_option("it")
    page.get_by_role("button", name="바꾸기").click()
    expect(page.get_by_role("heading", level=1)).to_have_text("Accedi")
    page.locator("#id_username").fill(nurse.username)
    page.locator("#id_password").fill(factories.PASSWORD)
    page.get_by_role("button", name="Accedi").click()

    expect(page.get_by_role("button", name="Esci")).to_be_visible()
    expect(page.get_by_role("link", name="Consegne", exact=True)).to_be_visible()

    page.get_by_label("Lingua").select_option("ko")
    page.get_by_role("button", name="Cambia").click()
    expect(page.get_by_role("button", name="로그아웃")).to_be_visible()
    assert Account.objects.get(user=nurse).language == "ko"


KOREAN_NAMES = {"1F-PHARM": "약제부", "2F-LAB": "진단검사실"}
AT_PHARMACY = {"floor": "1F", "waypoint": "1F-PHARM", "status": "waiting_load"}
AT_LAB = {"floor": "2F", "waypoint": "2F-LAB", "status": "waiting_unload"}


def korean_site():
    data = copy.deepcopy(factories.TINY_SITE)
    for floor in data["floors"]:
        for waypoint in floor["waypoints"]:
            if waypoint["code"] in KOREAN_NAMES:
                waypoint["names"] = {"ko": KOREAN_NAMES[waypoint["code"]]}
    return factories.site_create(**data)


def said_in(language: str, status: str) -> str:
    with translation.override(language):
        return str(TaskStatus(status).label)


def test_a_korean_nurse_follows_her_delivery_in_korean_while_an_operator_reads_english(
    chromium, page_servers, open_page, nurse, operator
):
    site = korean_site()
    robot = factories.robot_create(site, "R1")
    bot = RobotHttp(page_servers.http, robot)
    bot.heartbeat(1)  # R1 online at its dock
    korean = chromium.new_context(locale="ko-KR", viewport=PHONE, base_url=page_servers.http)
    nurse_page = korean.new_page()
    nurse_page.goto("/accounts/login/")
    nurse_page.locator("#id_username").fill(nurse.username)
    nurse_page.locator("#id_password").fill(factories.PASSWORD)
    nurse_page.get_by_role("button", name="로그인").click()
    expect(nurse_page.locator("#live-status")).to_have_text("실시간")
    operator_page = open_page(operator, "/")

    nurse_page.get_by_label("보내는 사람").fill("약제부")
    nurse_page.get_by_label("받는 사람").fill("김 간호사")
    nurse_page.get_by_label("내용물").fill("혈액 검체")
    nurse_page.get_by_label("픽업", exact=True).fill(KOREAN_NAMES["1F-PHARM"])
    nurse_page.get_by_label("배송지", exact=True).fill(KOREAN_NAMES["2F-LAB"])
    nurse_page.get_by_role("button", name="배송 요청").click()
    task = Task.objects.get(contents="혈액 검체")
    rows = [
        (page.locator(f'#schedule tr[data-task="{task.code}"]'), language)
        for page, language in ((nurse_page, "ko"), (operator_page, "en"))
    ]

    def both_read(status: str) -> None:
        for row, language in rows:
            expect(row.locator(".status")).to_have_text(said_in(language, status))

    # The server allocates a request at once (ALLOCATE_ON_REQUEST): R1 is chosen.
    both_read("assigned")
    expect(rows[0][0]).to_contain_text(f"{KOREAN_NAMES['1F-PHARM']} → {KOREAN_NAMES['2F-LAB']}")
    expect(rows[1][0]).to_contain_text("Pharmacy → Laboratory")
    plan = next(m for m in bot.heartbeat(2)["messages"] if m["type"] == "plan")
    bot.heartbeat(3, acks=[plan["id"]], state={"plan_version": plan["plan_version"]})
    both_read("acknowledged")
    bot.heartbeat(4, state=AT_PHARMACY, events=[event("loaded", task.code, 0)])
    both_read("picked_up")
    bot.heartbeat(5, state=AT_LAB, events=[event("arrived", task.code, 1)])
    bot.heartbeat(6, state=AT_LAB, events=[event("unloaded", task.code, 1)])
    both_read("delivered")
    bot.heartbeat(7, state=AT_LAB, events=[event("task_completed", task.code)])
    both_read("completed")

    assert said_in("ko", "completed") != said_in("en", "completed")
    assert nurse_page.evaluate("document.documentElement.scrollWidth <= window.innerWidth")
