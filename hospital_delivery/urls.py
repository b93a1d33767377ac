from django.contrib import admin
from django.contrib.auth import views as auth_views
from django.contrib.auth.decorators import login_required
from django.urls import include, path
from django.views.i18n import JavaScriptCatalog
from drf_spectacular.views import SpectacularAPIView, SpectacularSwaggerSplitView

from accounts.views import SignOutView
from hospital_delivery import healthz

# Swagger UI with its start-up script as a file of its own, not inline (Content-Security-Policy).
api_docs = SpectacularSwaggerSplitView.as_view(
    url_name="schema", template_name="api/swagger_ui.html"
)

urlpatterns = [
    path("admin/", admin.site.urls),
    path("healthz", healthz.healthz, name="healthz"),
    # The pages' scripts say their words in the page's language (gettext, interpolate).
    path("jsi18n/", JavaScriptCatalog.as_view(), name="javascript-catalog"),
    path("api/v1/", include("boards.urls")),
    path("api/v1/", include("robots.urls")),
    path("api/v1/", include("scheduling.urls")),
    path("api/v1/", include("maps.urls")),
    path("fhir/r4/", include("fhir_r4.urls")),  # orders from hospital systems (FHIR R4)
    path("api/schema/", SpectacularAPIView.as_view(), name="schema"),
    path("api/docs/", login_required(api_docs), name="api-docs"),
    # Pages for nurses and operators (ui/), and their login
    path("accounts/login/", auth_views.LoginView.as_view(), name="login"),
    path("accounts/logout/", SignOutView.as_view(), name="logout"),
    path("", include("accounts.urls")),  # /oidc/: single sign-on
    path("", include("ui.urls")),
    path("", include("reports.urls")),  # /reports/ and /metrics
    path("", include("webhooks.urls")),  # /webhooks/
    path("", include("audit.urls")),  # /audit/: the auditors' page and its exports
]
