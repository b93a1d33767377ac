"""In Chromium: a browser set to Korean gets the pages in Korean, the language menu switches them
(at a phone's width too), before and after a nurse signs in, and her choice is kept with her."""

from playwright.sync_api import expect

from accounts.models import Account
from tests import factories

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
