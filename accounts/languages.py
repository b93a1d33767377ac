"""Which language a person's pages are in: the one they chose from the language menu (kept with
their account, so it follows them to any computer), else their browser's Accept-Language, which
Django's LocaleMiddleware reads. The choice rides in the session, so no page pays a query for it."""

from django.conf import settings
from django.http import HttpRequest
from django.utils import translation

from accounts.models import Account

SESSION_KEY = "language"
# What robots, hospital systems and monitoring read: codes and English, whatever the caller's
# Accept-Language, since their error messages name fields and programs parse them.
MACHINE_PATHS = ("/api/v1/", "/api/schema/", "/fhir/", "/healthz", "/metrics")


def language_supported(code: str) -> bool:
    return code in dict(settings.LANGUAGES)


def account_language_set(*, user, language: str) -> None:
    """Keep a signed-in person's choice with their account (a local user gets their account row
    now: it says where their identity comes from, local by default)."""
    account, _created = Account.objects.get_or_create(user=user)
    account.language = language
    account.save(update_fields=["language"])


def language_of_page(*, session, cookies: dict, accept_language: str) -> str:
    """The language a page was rendered in, from what its live socket carries (the same session,
    cookies and Accept-Language): the person's choice, else as LocaleMiddleware chose it."""
    chosen = session.get(SESSION_KEY) if session is not None else None
    if chosen and language_supported(chosen):
        return chosen
    request = HttpRequest()
    request.COOKIES = cookies
    request.META["HTTP_ACCEPT_LANGUAGE"] = accept_language
    return translation.get_language_from_request(request)


def on_logged_in(sender, request, user, **kwargs) -> None:
    """django.contrib.auth's user_logged_in: the person's own language for the new session."""
    language = Account.objects.filter(user=user).values_list("language", flat=True).first()
    if language and language_supported(language):
        request.session[SESSION_KEY] = language


class PreferredLanguageMiddleware:
    """After LocaleMiddleware and the session: a person's chosen language replaces the one their
    browser asked for, and the machines' paths stay in the default language."""

    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        language = _chosen_language(request)
        if language:
            translation.activate(language)
            request.LANGUAGE_CODE = language
        return self.get_response(request)


def _chosen_language(request) -> str | None:
    if request.path.startswith(MACHINE_PATHS):
        return settings.LANGUAGE_CODE
    session = getattr(request, "session", None)
    language = session.get(SESSION_KEY) if session is not None else None
    return language if language and language_supported(language) else None
