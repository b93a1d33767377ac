"""The single sign-on's two steps (to the provider, back from it), signing out, which ends the
provider's session too for a user who came from it, and the language menu."""

from django.conf import settings
from django.contrib import messages
from django.contrib.auth.views import LogoutView
from django.http import Http404, HttpResponseBadRequest, HttpResponseRedirect
from django.shortcuts import redirect
from django.utils.http import url_has_allowed_host_and_scheme
from django.utils.translation import gettext as _
from django.views.decorators.http import require_POST
from django.views.generic import View
from mozilla_django_oidc.views import OIDCAuthenticationCallbackView, OIDCAuthenticationRequestView

from accounts import languages, oidc


class SignInView(OIDCAuthenticationRequestView):
    """The "Sign in with ..." button: to the provider's authorization endpoint, with state,
    nonce and a PKCE challenge kept in the session for the callback to check."""

    def __init__(self, **kwargs):
        # The authorization endpoint comes from discovery in get(), not from a setting.
        View.__init__(self, **kwargs)
        self.OIDC_RP_CLIENT_ID = self.get_settings("OIDC_RP_CLIENT_ID")

    def get(self, request):
        if not oidc.enabled():
            raise Http404("single sign-on is not configured")
        try:
            self.OIDC_OP_AUTH_ENDPOINT = oidc.provider_metadata()["authorization_endpoint"]
        except oidc.ProviderUnavailable:
            messages.error(request, oidc.unavailable_message())
            return redirect("login")
        return super().get(request)


class CallbackView(OIDCAuthenticationCallbackView):
    """Back from the provider: the state must be one the browser's own session started (else
    400), then the backend exchanges the code and checks the ID token
    (accounts.backends.SingleSignOnBackend)."""

    def get(self, request):
        if not oidc.enabled():
            raise Http404("single sign-on is not configured")
        return super().get(request)

    def login_failure(self):
        messages.error(self.request, oidc.failed_message())
        return redirect("login")


class SignOutView(LogoutView):
    """Django's logout; for a user of the single sign-on, then on to the provider to end its
    session (it sends them back to the login page)."""

    def post(self, request, *args, **kwargs):
        provider_end = oidc.end_session_url(request)  # read before the session is flushed
        response = super().post(request, *args, **kwargs)
        return redirect(provider_end) if provider_end else response


@require_POST
def language_choose(request):
    """The language menu: the chosen language for this browser (Django's language cookie) and,
    for a signed-in person, for them wherever they sign in. Back to the page it was chosen on."""
    language = request.POST.get("language", "")
    if not languages.language_supported(language):
        return HttpResponseBadRequest(
            _("language: choose one of %(choices)s")
            % {"choices": ", ".join(code for code, _name in settings.LANGUAGES)},
            content_type="text/plain; charset=utf-8",
        )
    if request.user.is_authenticated:
        languages.account_language_set(user=request.user, language=language)
        request.session[languages.SESSION_KEY] = language
    back = request.POST.get("next", "")
    if not url_has_allowed_host_and_scheme(
        back, allowed_hosts={request.get_host()}, require_https=request.is_secure()
    ):
        back = "/"
    response = HttpResponseRedirect(back)
    response.set_cookie(
        settings.LANGUAGE_COOKIE_NAME,
        language,
        max_age=settings.LANGUAGE_COOKIE_AGE,
        samesite=settings.LANGUAGE_COOKIE_SAMESITE,
        secure=settings.LANGUAGE_COOKIE_SECURE,
        httponly=settings.LANGUAGE_COOKIE_HTTPONLY,
    )
    return response
