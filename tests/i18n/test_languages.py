"""The pages' language: the browser's Accept-Language by default, the language menu's choice for
that browser, a signed-in person's choice wherever they sign in next; robots' and hospital
systems' paths stay in English; each catalog complete."""

import re
import subprocess
from pathlib import Path

import pytest
from django.conf import settings
from django.contrib.auth import get_user_model
from django.test import Client

from accounts.models import Account
from tests import factories

LOCALE = Path(settings.BASE_DIR) / "locale"


def heading(response) -> str:
    return re.search(r"<h1[^>]*>(.*?)</h1>", response.content.decode()).group(1)


def html_lang(response) -> str:
    return re.search(r'<html lang="([^"]+)"', response.content.decode()).group(1)


@pytest.mark.parametrize(
    ("accept", "lang", "title"),
    [
        ("ko-KR,ko;q=0.9,en;q=0.5", "ko", "로그인"),
        ("it-IT,it;q=0.9", "it", "Accedi"),
        ("", "en", "Log in"),
    ],
)
def test_it_speaks_the_browsers_language(client, accept, lang, title):
    response = client.get("/accounts/login/", HTTP_ACCEPT_LANGUAGE=accept)

    assert response.status_code == 200
    assert (html_lang(response), heading(response)) == (lang, title)
    assert response["Content-Language"] == lang


def test_a_language_it_does_not_have_falls_back_to_english(client):
    response = client.get("/accounts/login/", HTTP_ACCEPT_LANGUAGE="fr-FR,fr;q=0.9")

    assert heading(response) == "Log in"


def test_the_menu_choice_holds_for_the_browser_over_its_accept_language(client):
    response = client.post("/language/", {"language": "it", "next": "/accounts/login/"})

    assert (response.status_code, response["Location"]) == (302, "/accounts/login/")
    assert client.cookies[settings.LANGUAGE_COOKIE_NAME].value == "it"
    later = client.get("/accounts/login/", HTTP_ACCEPT_LANGUAGE="ko-KR,ko")
    assert heading(later) == "Accedi"


def test_a_signed_in_persons_choice_follows_them_to_another_browser(db, nurse):
    first = Client()
    first.force_login(nurse)
    first.post("/language/", {"language": "ko", "next": "/"})

    assert Account.objects.get(user=nurse).language == "ko"
    other = Client(HTTP_ACCEPT_LANGUAGE="it-IT,it")
    other.post("/accounts/login/", {"username": "kim", "password": factories.PASSWORD})
    page = other.get("/stations/")
    assert html_lang(page) == "ko"
    assert "로그아웃" in page.content.decode()


def test_an_unknown_language_is_refused_naming_the_field_and_changes_nothing(db, nurse):
    client = Client()
    client.force_login(nurse)

    response = client.post("/language/", {"language": "xx", "next": "/"})

    assert response.status_code == 400
    assert response.content.decode().startswith("language: ")
    assert settings.LANGUAGE_COOKIE_NAME not in response.cookies
    assert not Account.objects.filter(user=nurse).exists()


def test_it_goes_back_only_to_its_own_pages(client):
    response = client.post("/language/", {"language": "ko", "next": "https://evil.example/"})

    assert response["Location"] == "/"


def test_the_menu_takes_only_a_post(client):
    assert client.get("/language/?language=ko").status_code == 405


def test_robots_and_hospital_systems_get_english_whatever_they_ask(db, site):
    robot = factories.robot_create(site, "R1")
    client = Client(HTTP_ACCEPT_LANGUAGE="ko-KR,ko")

    response = client.post(
        f"/api/v1/robots/{robot.code}/heartbeat",
        data="{}",
        content_type="application/json",
        HTTP_AUTHORIZATION="Bearer not-a-token",
    )

    assert response.status_code in (401, 403)
    assert response["Content-Language"] == "en"
    assert not re.search("[\uac00-\ud7a3]", response.content.decode())


def test_the_lock_out_page_speaks_korean(rf, db):
    from django.template.loader import render_to_string
    from django.utils import translation

    request = rf.get("/accounts/login/")
    request.user = get_user_model()(username="kim")
    with translation.override("ko"):
        html = render_to_string(
            "registration/locked_out.html",
            {"username": "kim", "cooloff_timedelta": "0:15:00", "request": request},
        )

    assert "<strong>kim</strong>의 비밀번호가 너무 많이 틀렸습니다" in html
    assert "Too many" not in html


@pytest.mark.parametrize("domain", ["django", "djangojs"])
@pytest.mark.parametrize("language", ["ko", "it"])
def test_each_catalog_is_complete(language, domain):
    catalog = LOCALE / language / "LC_MESSAGES" / f"{domain}.po"

    checked = subprocess.run(
        ["msgfmt", "--check", "--statistics", "-o", "/dev/null", str(catalog)],
        capture_output=True,
        text=True,
    )

    assert checked.returncode == 0, checked.stderr
    assert re.fullmatch(r"\d+ translated messages\.\n", checked.stderr), checked.stderr
