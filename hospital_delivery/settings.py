"""The one settings module. Every value a deployment may change comes from the environment.

Bad values stop the process at start-up (see env.py) instead of surfacing later.
"""

import ipaddress
from datetime import timedelta
from pathlib import Path

import dj_database_url
import ldap
from django.core.exceptions import ImproperlyConfigured
from django_auth_ldap.config import (
    GroupOfNamesType,
    LDAPSearch,
    NestedGroupOfNamesType,
    PosixGroupType,
)

from accounts.groups import GroupsSyntaxError, parse_role_groups, parse_site_groups
from hospital_delivery.env import env_bool, env_int, env_list, env_str

BASE_DIR = Path(__file__).resolve().parent.parent

DEBUG = env_bool("DEBUG", False)
# The key run.sh generates into var/secret_key is read from there by every command
# (manage.py robot_token R3 as the README shows it) when SECRET_KEY is not set.
SECRET_KEY_FILE = Path(env_str("SECRET_KEY_FILE", str(BASE_DIR / "var" / "secret_key")))
SECRET_KEY = env_str("SECRET_KEY", "")
if not SECRET_KEY and SECRET_KEY_FILE.is_file():
    SECRET_KEY = SECRET_KEY_FILE.read_text(encoding="utf-8").strip()
if not SECRET_KEY:
    if not DEBUG:
        raise ImproperlyConfigured("SECRET_KEY must be set when DEBUG is off")
    SECRET_KEY = "insecure-development-key-do-not-use-in-production"
ALLOWED_HOSTS = env_list("ALLOWED_HOSTS", ["localhost", "127.0.0.1", "[::1]"])
CSRF_TRUSTED_ORIGINS = env_list("CSRF_TRUSTED_ORIGINS", [])

# Serving over HTTPS (docs/deployment/production.md): HTTPS=true makes cookies Secure, sends
# HSTS and redirects plain HTTP (except /healthz, which load balancers probe). Behind a TLS proxy,
# SECURE_PROXY_SSL_HEADER names the header it sets, e.g. X-Forwarded-Proto=https (only
# where the proxy overwrites that header: a client could send it otherwise).
HTTPS = env_bool("HTTPS", False)
SESSION_COOKIE_SECURE = CSRF_COOKIE_SECURE = HTTPS
SECURE_SSL_REDIRECT = env_bool("SECURE_SSL_REDIRECT", HTTPS)
SECURE_REDIRECT_EXEMPT = [r"^healthz$"]
SECURE_HSTS_SECONDS = env_int("HSTS_SECONDS", 31536000 if HTTPS else 0, minimum=0)
SECURE_HSTS_INCLUDE_SUBDOMAINS = env_bool("HSTS_INCLUDE_SUBDOMAINS", True)
SECURE_HSTS_PRELOAD = env_bool("HSTS_PRELOAD", True)  # no effect unless submitted to the list
_proxy_header = env_str("SECURE_PROXY_SSL_HEADER", "")
if _proxy_header:
    _name, _, _value = _proxy_header.partition("=")
    if not (_name.strip() and _value.strip()):
        raise ImproperlyConfigured(
            f"SECURE_PROXY_SSL_HEADER={_proxy_header!r}: use HEADER=value (X-Forwarded-Proto=https)"
        )
    SECURE_PROXY_SSL_HEADER = (
        "HTTP_" + _name.strip().upper().replace("-", "_"),
        _value.strip(),
    )
SESSION_COOKIE_HTTPONLY = True

INSTALLED_APPS = [
    "daphne",
    "django.contrib.admin",
    "django.contrib.auth",
    "django.contrib.contenttypes",
    "django.contrib.sessions",
    "django.contrib.messages",
    "whitenoise.runserver_nostatic",
    "django.contrib.staticfiles",
    "rest_framework",
    "drf_spectacular",
    "drf_spectacular_sidecar",
    "axes",
    "channels",
    "csp",
    # django-auditlog records model changes into audit.AuditEntry (AUDITLOG_LOGENTRY_MODEL);
    # before audit, whose admin replaces auditlog's.
    "auditlog",
    # Components, lowest layer first (pyproject.toml, [tool.importlinter]).
    "robots",
    "audit",
    "boards",
    "resources",
    "building",
    "scheduling",
    "accounts",
    "maps",
    "fhir_r4",
    "ui",
    "reports",
    "webhooks",
    "vda5050",
    "hospital_delivery",
]

MIDDLEWARE = [
    "django.middleware.security.SecurityMiddleware",
    "core.middleware.RefuseNulMiddleware",
    "whitenoise.middleware.WhiteNoiseMiddleware",
    "django.contrib.sessions.middleware.SessionMiddleware",
    "django.middleware.locale.LocaleMiddleware",
    "django.middleware.common.CommonMiddleware",
    "django.middleware.csrf.CsrfViewMiddleware",
    "django.contrib.auth.middleware.AuthenticationMiddleware",
    # A signed-in person's own language wins over their browser's.
    "accounts.languages.PreferredLanguageMiddleware",
    # The actor and client address of the audit entries a request writes (audit/context.py).
    "audit.middleware.AuditContextMiddleware",
    "django.contrib.messages.middleware.MessageMiddleware",
    "django.middleware.clickjacking.XFrameOptionsMiddleware",
    "core.middleware.CSPMiddleware",  # django-csp's, its policy built once
    # A person's request keeps their session alive for SESSION_IDLE_MINUTES more.
    "hospital_delivery.sessions.SessionIdleMiddleware",
    # Sign-in posts from an address with too many failures: the lock-out page, before the view
    # hashes a password (hospital_delivery/signin.py).
    "hospital_delivery.signin.SignInThrottleMiddleware",
    # Last, as django-axes requires: it answers a locked-out login with the lockout page.
    "axes.middleware.AxesMiddleware",
]

ROOT_URLCONF = "hospital_delivery.urls"
WSGI_APPLICATION = "hospital_delivery.wsgi.application"
ASGI_APPLICATION = "hospital_delivery.asgi.application"

TEMPLATES = [
    {
        "BACKEND": "django.template.backends.django.DjangoTemplates",
        "DIRS": [BASE_DIR / "templates"],
        "APP_DIRS": True,
        "OPTIONS": {
            "context_processors": [
                "django.template.context_processors.request",
                "django.contrib.auth.context_processors.auth",
                "django.contrib.messages.context_processors.messages",
                "ui.context_processors.pages",
            ],
        },
    },
]

# Database: SQLite (WAL, immediate transactions so writers queue instead of failing)
# unless DATABASE_URL names another one, e.g. postgres://user@127.0.0.1:5432/hospital_delivery.
DATABASE_URL = env_str("DATABASE_URL", f"sqlite:///{BASE_DIR / 'db.sqlite3'}")
try:
    DATABASES = {
        "default": dj_database_url.parse(
            DATABASE_URL, conn_max_age=env_int("DATABASE_CONN_MAX_AGE", 60, minimum=0)
        )
    }
except ValueError as exc:
    raise ImproperlyConfigured(f"DATABASE_URL is not a database URL: {exc}") from None
if DATABASES["default"]["ENGINE"] == "django.db.backends.sqlite3":
    DATABASES["default"]["CONN_MAX_AGE"] = 0
    DATABASES["default"]["OPTIONS"] = {
        "transaction_mode": "IMMEDIATE",
        "timeout": 20,
        "init_command": "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;",
    }
    DATABASES["default"]["TEST"] = {"NAME": str(BASE_DIR / "var" / "test.sqlite3")}
DEFAULT_AUTO_FIELD = "django.db.models.BigAutoField"
# On PostgreSQL, values are bound by the server and a statement run 5 times on a connection is
# prepared there (Django's server_side_binding; psycopg's prepare_threshold, at psycopg's own
# default): the hot paths' statements are parsed and planned once per connection. Turn off
# behind a connection pooler that does not keep prepared statements (PgBouncer in transaction
# mode before 1.21).
DATABASE_PREPARED_STATEMENTS = env_bool("DATABASE_PREPARED_STATEMENTS", True)
if DATABASES["default"]["ENGINE"] == "django.db.backends.postgresql" and (
    DATABASE_PREPARED_STATEMENTS
):
    DATABASES["default"].setdefault("OPTIONS", {}).update(
        server_side_binding=True, prepare_threshold=5
    )

REDIS_URL = env_str("REDIS_URL", "redis://127.0.0.1:6379/0")

# Where the pages' websockets connect. Behind the proxy (nginx, scripts/run.sh) pages and sockets
# share one origin, so by default a page connects to ws(s)://<its own host and port>/ws/...
# WEBSOCKET_URL (e.g. ws://127.0.0.1:8001, daphne itself) or WEBSOCKET_PORT (the page's host,
# another port) point them elsewhere, for servers run without the proxy.
WEBSOCKET_URL = env_str("WEBSOCKET_URL", "")
WEBSOCKET_PORT = env_int("WEBSOCKET_PORT", 0, minimum=0) or ""

# Content-Security-Policy (django-csp): scripts and style sheets from our own files only, no
# inline <script> or <style>. Style attributes stay allowed: the pages draw battery bars and
# map markers with them (style="--level: 80%"), which run no code. Websockets go to daphne on
# another port (or WEBSOCKET_URL), which 'self' does not cover.
_websocket_sources = [WEBSOCKET_URL] if WEBSOCKET_URL else ["ws:", "wss:"]
CONTENT_SECURITY_POLICY = {
    "DIRECTIVES": {
        "default-src": ["'self'"],
        "script-src": ["'self'"],
        "style-src": ["'self'"],
        "style-src-attr": ["'unsafe-inline'"],
        "img-src": ["'self'", "data:"],
        "connect-src": ["'self'", *_websocket_sources],
        "object-src": ["'none'"],
        "base-uri": ["'self'"],
        "form-action": ["'self'"],
        "frame-ancestors": ["'none'"],
    },
}

CACHES = {
    "default": {"BACKEND": "django.core.cache.backends.locmem.LocMemCache"},
}

AUTH_PASSWORD_VALIDATORS = [
    {"NAME": "django.contrib.auth.password_validation.MinimumLengthValidator"},
    {"NAME": "django.contrib.auth.password_validation.CommonPasswordValidator"},
]
# Login throttling (django-axes), on the login page and the admin's: after LOGIN_FAILURE_LIMIT
# wrong passwords for one username from one address, that pair is locked out for
# LOGIN_LOCKOUT_MINUTES (a correct password included). Per pair, so that nobody can lock a
# nurse out from elsewhere. Administrators unlock in the admin (Axes > Access attempts: delete)
# or with `manage.py axes_reset_username USERNAME`.
AUTHENTICATION_BACKENDS = [
    "axes.backends.AxesStandaloneBackend",
    "django.contrib.auth.backends.ModelBackend",
]
AXES_FAILURE_LIMIT = env_int("LOGIN_FAILURE_LIMIT", 5, minimum=1)
AXES_COOLOFF_TIME = timedelta(minutes=env_int("LOGIN_LOCKOUT_MINUTES", 15, minimum=1))
AXES_LOCKOUT_PARAMETERS = [["username", "ip_address"]]
AXES_RESET_ON_SUCCESS = True
AXES_LOCKOUT_TEMPLATE = "registration/locked_out.html"
AXES_VERBOSE = False
# The client's address: behind a proxy every request comes from the proxy, so the address is
# read from X-Forwarded-For, trusting as many entries from its right as there are proxies in
# front of Django that append to it (core/clientaddress.py). 1: the nginx of scripts/run.sh
# (hospital_delivery/proxy.py); 0: Django reached directly; 2: a load balancer before it.
TRUSTED_PROXY_COUNT = env_int("TRUSTED_PROXY_COUNT", 1, minimum=0)
AXES_CLIENT_IP_CALLABLE = "core.clientaddress.client_address"
# Failed sign-ins from one address, whatever the usernames, within LOGIN_LOCKOUT_MINUTES after
# which that address's sign-ins are refused before any password is hashed until the window
# ends (hospital_delivery/signin.py). Above LOGIN_FAILURE_LIMIT: a nurses' station shared by
# several people stays usable while one of them is locked out.
LOGIN_ADDRESS_FAILURE_LIMIT = env_int("LOGIN_ADDRESS_FAILURE_LIMIT", 20, minimum=1)

# Pages' sessions end after SESSION_IDLE_MINUTES without a request of the person using them
# (hospital_delivery/sessions.py): nurses' stations are shared, and a page left open must not
# stay signed in. The live pages' own re-reads of the state do not count as use.
SESSION_IDLE_MINUTES = env_int("SESSION_IDLE_MINUTES", 30, minimum=1)
SESSION_COOKIE_AGE = SESSION_IDLE_MINUTES * 60
# An open page's websocket checks that its session and user still may watch the site this often
# (ui/live/consumers.py), besides at once when the user is changed.
LIVE_ACCESS_RECHECK_SECONDS = env_int("LIVE_ACCESS_RECHECK_SECONDS", 60, minimum=1)

# The audit trail (audit/, docs/administrators/audit.md). django-auditlog writes its entries of
# model changes into audit.AuditEntry, which chains them with the events the services record.
AUDITLOG_LOGENTRY_MODEL = "audit.AuditEntry"
# The records whose changes are audited, and the fields left out (changed by the system on its
# own, e.g. at each sign-in) or masked (secrets and their hashes: that they changed is kept).
AUDITLOG_INCLUDE_TRACKING_MODELS = (
    {
        "model": "auth.user",
        "exclude_fields": ["last_login"],
        "mask_fields": ["password"],
        "m2m_fields": {"groups", "user_permissions"},
    },
    {"model": "auth.group", "m2m_fields": {"permissions"}},
    {
        "model": "robots.sitemembership",
        "mask_fields": ["badge_salt", "badge_hash"],
    },
    {"model": "accounts.account", "exclude_fields": ["synced_at"], "mask_fields": ["pin_hash"]},
    "accounts.workstation",
    {"model": "hospital_delivery.apitoken", "mask_fields": ["token_hash"]},
    {"model": "webhooks.subscription", "mask_fields": ["secret"]},
    "robots.site",
    {
        "model": "robots.resource",
        # Out of service is an operator's action (audited as one) or a device's fault.
        "exclude_fields": ["out_of_service_since", "out_of_service_reason"],
    },
)
AUDITLOG_MASK_CALLABLE = "audit.masking.secret_masked"
# django-auditlog's own migrations create its default entry table, which stays empty here and
# whose foreign key to the content types would stop the test databases from being flushed.
MIGRATION_MODULES = {"auditlog": None}
# Entries older than this many days are removed by a daily sweep, which records what it removed;
# 0 keeps every entry. HIPAA asks for six years of such records (45 CFR 164.316(b)(2)).
AUDIT_RETENTION_DAYS = env_int("AUDIT_RETENTION_DAYS", 6 * 366, minimum=0)

LOGIN_URL = "login"
LOGIN_REDIRECT_URL = "/"
LOGOUT_REDIRECT_URL = "login"

# The pages speak English, Korean and Italian: a person's stored choice, else their browser's
# Accept-Language (accounts/languages.py). What robots and integrators receive stays in codes
# and English.
LANGUAGE_CODE = "en"
LANGUAGES = [("en", "English"), ("ko", "한국어"), ("it", "Italiano")]
LOCALE_PATHS = [BASE_DIR / "locale"]
# The menu's choice on a computer nobody signed in on lasts a year, like the hospital's other
# preferences; a signed-in person's follows them (accounts/languages.py).
LANGUAGE_COOKIE_AGE = 365 * 24 * 3600
LANGUAGE_COOKIE_SECURE = HTTPS
LANGUAGE_COOKIE_HTTPONLY = True
TIME_ZONE = env_str("TIME_ZONE", "Asia/Seoul")
USE_I18N = True
USE_TZ = True

STATIC_URL = "static/"
STATICFILES_DIRS = [BASE_DIR / "static"]
STATIC_ROOT = BASE_DIR / "var" / "staticfiles"
# Also serve straight from the apps' and static/ directories (found at start-up), so the pages
# work where `collectstatic` has not run (test servers); run.sh collects them anyway.
WHITENOISE_USE_FINDERS = True
STORAGES = {
    "default": {"BACKEND": "django.core.files.storage.FileSystemStorage"},
    "staticfiles": {"BACKEND": "whitenoise.storage.CompressedStaticFilesStorage"},
}

REST_FRAMEWORK = {
    "DEFAULT_AUTHENTICATION_CLASSES": [
        # Token first: its WWW-Authenticate header makes anonymous requests 401, not 403.
        "hospital_delivery.authentication.ApiTokenAuthentication",
        "rest_framework.authentication.SessionAuthentication",
    ],
    "DEFAULT_PERMISSION_CLASSES": ["rest_framework.permissions.IsAdminUser"],
    # Depth- and size-bounded JSON, refusing text the database cannot store (jsonbody.py).
    "DEFAULT_PARSER_CLASSES": [
        "core.jsonbody.BoundedJSONParser",
        "rest_framework.parsers.FormParser",
        "rest_framework.parsers.MultiPartParser",
    ],
    "DEFAULT_SCHEMA_CLASS": "drf_spectacular.openapi.AutoSchema",
    "EXCEPTION_HANDLER": "core.errors.exception_handler",
    "DEFAULT_PAGINATION_CLASS": "core.pagination.BoundedLimitOffsetPagination",
    "PAGE_SIZE": 100,
}
SPECTACULAR_SETTINGS = {
    "TITLE": "hospital_delivery API",
    "DESCRIPTION": "Fleet server for hospital delivery robots: the robot heartbeat and "
    "message board (protocol v1), the device catalog and delivery tasks.",
    "VERSION": "1",
    "SERVE_INCLUDE_SCHEMA": False,
    # Like every page, the schema needs a login; the docs page loads Swagger UI from our own
    # static files (drf-spectacular-sidecar), so it works on an intranet without internet.
    "SERVE_PERMISSIONS": ["rest_framework.permissions.IsAuthenticated"],
    "SWAGGER_UI_DIST": "SIDECAR",
    "SWAGGER_UI_FAVICON_HREF": "SIDECAR",
    "REDOC_DIST": "SIDECAR",
    "COMPONENT_SPLIT_REQUEST": True,
}

# Hospital sign-in (docs/deployment/sign-in.md): the hospital's LDAP directory or Active
# Directory, and OpenID Connect single sign-on, beside the local accounts (break-glass
# administrators, the demo); roles and sites from the directory's groups at each sign-in;
# shared ward workstations. Each part is off until its setting names a server.
AUTH_LDAP_SERVER_URI = env_str("AUTH_LDAP_SERVER_URI", "").strip()
AUTH_LDAP_BIND_DN = env_str("AUTH_LDAP_BIND_DN", "")
AUTH_LDAP_BIND_PASSWORD = env_str("AUTH_LDAP_BIND_PASSWORD", "")
AUTH_LDAP_START_TLS = env_bool("AUTH_LDAP_START_TLS", False)
AUTH_LDAP_USER_SEARCH = AUTH_LDAP_GROUP_SEARCH = None
_ldap_user_base = env_str("AUTH_LDAP_USER_SEARCH_BASE", "").strip()
_ldap_user_filter = env_str("AUTH_LDAP_USER_SEARCH_FILTER", "(uid=%(user)s)").strip()
_ldap_group_base = env_str("AUTH_LDAP_GROUP_SEARCH_BASE", "").strip()
_ldap_group_filter = env_str("AUTH_LDAP_GROUP_SEARCH_FILTER", "(objectClass=*)").strip()
_ldap_group_types = {
    "member": GroupOfNamesType,  # groups listing their members' DNs: groupOfNames, AD groups
    "nested": NestedGroupOfNamesType,  # the same, and groups within groups (AD's nesting)
    "posix": PosixGroupType,  # posixGroup listing memberUid
}
_ldap_group_type = env_str("AUTH_LDAP_GROUP_TYPE", "member")
_ldap_ca_file = env_str("AUTH_LDAP_CA_FILE", "")
_ldap_timeout = env_int("AUTH_LDAP_TIMEOUT", 5, minimum=1)
if _ldap_group_type not in _ldap_group_types:
    raise ImproperlyConfigured(
        f"AUTH_LDAP_GROUP_TYPE={_ldap_group_type!r}: use one of {', '.join(_ldap_group_types)}"
    )
if AUTH_LDAP_SERVER_URI:
    for _uri in AUTH_LDAP_SERVER_URI.split():
        if not _uri.startswith(("ldap://", "ldaps://")):
            raise ImproperlyConfigured(f"AUTH_LDAP_SERVER_URI: {_uri!r} is not ldap:// or ldaps://")
        if AUTH_LDAP_START_TLS and _uri.startswith("ldaps://"):
            raise ImproperlyConfigured(
                "AUTH_LDAP_START_TLS is for ldap:// (ldaps:// is TLS already)"
            )
    if not _ldap_user_base:
        raise ImproperlyConfigured(
            "AUTH_LDAP_USER_SEARCH_BASE must be set with AUTH_LDAP_SERVER_URI"
        )
    if "%(user)s" not in _ldap_user_filter:
        raise ImproperlyConfigured("AUTH_LDAP_USER_SEARCH_FILTER must contain %(user)s")
    if _ldap_ca_file and not Path(_ldap_ca_file).is_file():
        raise ImproperlyConfigured(f"AUTH_LDAP_CA_FILE={_ldap_ca_file!r} is not a file")
    AUTH_LDAP_USER_SEARCH = LDAPSearch(_ldap_user_base, ldap.SCOPE_SUBTREE, _ldap_user_filter)
    if _ldap_group_base:
        AUTH_LDAP_GROUP_SEARCH = LDAPSearch(
            _ldap_group_base, ldap.SCOPE_SUBTREE, _ldap_group_filter
        )
        AUTH_LDAP_GROUP_TYPE = _ldap_group_types[_ldap_group_type]()
AUTH_LDAP_USER_ATTR_MAP = {"first_name": "givenName", "last_name": "sn", "email": "mail"}
AUTH_LDAP_CONNECTION_OPTIONS = {
    ldap.OPT_REFERRALS: 0,  # Active Directory's referrals lead to other servers: not followed
    ldap.OPT_NETWORK_TIMEOUT: _ldap_timeout,  # a directory that is down must not hang sign-ins
    ldap.OPT_TIMEOUT: _ldap_timeout,
    ldap.OPT_X_TLS_REQUIRE_CERT: ldap.OPT_X_TLS_DEMAND,
    **({ldap.OPT_X_TLS_CACERTFILE: _ldap_ca_file} if _ldap_ca_file else {}),
    ldap.OPT_X_TLS_NEWCTX: 0,  # last: applies the TLS options above
}

OIDC_ISSUER = env_str("OIDC_ISSUER", "").strip()
OIDC_RP_CLIENT_ID = env_str("OIDC_CLIENT_ID", "")
OIDC_RP_CLIENT_SECRET = env_str("OIDC_CLIENT_SECRET", "")
OIDC_GROUPS_CLAIM = env_str("OIDC_GROUPS_CLAIM", "groups")
OIDC_USERNAME_CLAIM = env_str("OIDC_USERNAME_CLAIM", "preferred_username")
OIDC_PROVIDER_NAME = env_str("OIDC_PROVIDER_NAME", "single sign-on")
OIDC_RP_SCOPES = env_str("OIDC_SCOPES", "openid email profile")
OIDC_RP_SIGN_ALGO = env_str("OIDC_SIGN_ALGORITHM", "RS256")
OIDC_TIMEOUT = env_int("OIDC_TIMEOUT", 10, minimum=1)
OIDC_USE_PKCE = True  # RFC 7636, S256: a stolen authorization code is useless alone
OIDC_STORE_ID_TOKEN = True  # the id_token_hint of the provider's sign-out
if OIDC_ISSUER:
    _issuer_host = OIDC_ISSUER.split("://", 1)[-1].split("/", 1)[0].rsplit(":", 1)[0]
    if not (OIDC_ISSUER.startswith("https://") or _issuer_host in ("127.0.0.1", "localhost")):
        raise ImproperlyConfigured("OIDC_ISSUER must be an https:// URL")
    if not (OIDC_RP_CLIENT_ID and OIDC_RP_CLIENT_SECRET):
        raise ImproperlyConfigured(
            "OIDC_CLIENT_ID and OIDC_CLIENT_SECRET must be set with OIDC_ISSUER"
        )
    if "openid" not in OIDC_RP_SCOPES.split():
        raise ImproperlyConfigured(f"OIDC_SCOPES={OIDC_RP_SCOPES!r} must include openid")
    if not OIDC_RP_SIGN_ALGO.startswith(("RS", "ES", "PS")):
        raise ImproperlyConfigured("OIDC_SIGN_ALGORITHM must be one the provider signs with a key")
    # Signing out posts a form whose answer sends the browser on to the provider's sign-out.
    CONTENT_SECURITY_POLICY["DIRECTIVES"]["form-action"].append(
        "/".join(OIDC_ISSUER.split("/", 3)[:3])
    )

try:
    ROLE_GROUPS = parse_role_groups(env_str("ROLE_GROUPS", ""))
    SITE_GROUPS = parse_site_groups(env_str("SITE_GROUPS", ""))
except GroupsSyntaxError as exc:
    raise ImproperlyConfigured(str(exc)) from None

AUTHENTICATION_BACKENDS = [
    AUTHENTICATION_BACKENDS[0],  # django-axes stays first: it refuses locked-out attempts
    *(["accounts.backends.DirectoryBackend"] if AUTH_LDAP_SERVER_URI else []),
    *(["accounts.backends.SingleSignOnBackend"] if OIDC_ISSUER else []),
    *AUTHENTICATION_BACKENDS[1:],
    # A person confirming an order at a workstation. Last: Django's test client signs in
    # (force_login) with the first backend that can find a user, and this one never does.
    "accounts.backends.BadgePinBackend",
]
# What django-axes keeps of a failed attempt's form masks these (a workstation's badge and PIN).
AXES_SENSITIVE_PARAMETERS = ["username", "ip_address", "badge", "pin"]

# How the scheduler gives out tasks (measured side by side in bench/fleet_day.py):
# "delivery_time" (default): online multi-task allocation choosing the robot by added travel
#   plus the waiting it causes (scheduling.allocator.allocate_for_delivery_time);
# "paper": the source paper's rule (Sec. 3.1.2): a standby robot first (of several, the one
#   reaching the pick-up soonest), else the robot whose route the task lengthens least;
# "least_travel": the robot whose route the task lengthens least, standby or not;
# "single": a robot takes a task only when it holds none, as fleets ran before the paper.
ALLOCATION_POLICIES = ("delivery_time", "paper", "least_travel", "single")
ALLOCATION_POLICY = env_str("ALLOCATION_POLICY", "delivery_time")
if ALLOCATION_POLICY not in ALLOCATION_POLICIES:
    raise ImproperlyConfigured(
        f"ALLOCATION_POLICY={ALLOCATION_POLICY!r}: use one of {', '.join(ALLOCATION_POLICIES)}"
    )

# A request due now is allocated in the request itself when no allocation is running on its
# site, so it commits with its robot chosen and the plan posted (bench/latency.py); otherwise,
# and always when this is off, by the Celery worker.
ALLOCATE_ON_REQUEST = env_bool("ALLOCATE_ON_REQUEST", True)

# Digits of a secure delivery's PIN (scheduling/pins.py): each digit makes guessing a PIN from
# a robot's stored plan ten times slower (docs/deployment/security.md, "PINs"). Six only for
# robots whose keypads take no more; the plan tells robots the length (secure.pin.digits).
SECURE_PIN_DIGITS = env_int("SECURE_PIN_DIGITS", 8, minimum=6)
if SECURE_PIN_DIGITS > 12:
    raise ImproperlyConfigured(f"SECURE_PIN_DIGITS={SECURE_PIN_DIGITS}: at most 12")

# Bearer token that may scrape /metrics (besides operators' and staff's logins); none if empty.
METRICS_TOKEN = env_str("METRICS_TOKEN", "")

# Robot heartbeat bodies above this size are refused with 413 (protocol v1).
HEARTBEAT_MAX_BYTES = 64 * 1024

# The operator's ceiling of heartbeats per second the web nodes are asked for together: when the
# fleet would send more at the sites' intervals, every robot is told a longer heartbeat_interval
# (core/overload.py), as it is whenever heartbeats wait long for a web worker (the proxy's
# X-Request-Start stamp). 0 turns every lengthening off. 1,000 by default, about what a bare
# endpoint takes on 2 cores: below it the measured wait does the work.
HEARTBEAT_CAPACITY = env_int("HEARTBEAT_CAPACITY", 1000, minimum=0)
# The longest interval ever told; with many robots on a small server, past it heartbeats queue.
HEARTBEAT_INTERVAL_MAX = env_int("HEARTBEAT_INTERVAL_MAX", 10, minimum=1)
# Seconds told to a robot idle (nothing on board, nothing to report) that holds
# the push channel open, which wakes it at once for anything posted (boards/services.py); the
# site's interval when that is longer. 0: every robot is told its site's interval.
HEARTBEAT_IDLE_INTERVAL = env_int("HEARTBEAT_IDLE_INTERVAL", 5, minimum=0)

# Push sockets one robot may hold open at once (protocol v1, "Push channel"): a newer one
# closes the oldest with 4409 (boards/consumers.py).
PUSH_SOCKETS_PER_ROBOT = env_int("PUSH_SOCKETS_PER_ROBOT", 3, minimum=1)

CHANNEL_LAYERS = {
    "default": {
        "BACKEND": "channels_redis.pubsub.RedisPubSubChannelLayer",
        # The prefix keeps two deployments (or test runs) sharing one Redis apart: pub/sub
        # channels ignore Redis database numbers.
        "CONFIG": {"hosts": [REDIS_URL], "prefix": env_str("CHANNELS_PREFIX", "hospital_delivery")},
    },
}

CELERY_BROKER_URL = REDIS_URL
# The queue tasks are sent to and the worker reads (two deployments, or test servers, sharing one
# Redis database keep apart by naming their own).
CELERY_TASK_DEFAULT_QUEUE = env_str("CELERY_QUEUE", "celery")
CELERY_TASK_IGNORE_RESULT = True
CELERY_TASK_ACKS_LATE = True
CELERY_WORKER_PREFETCH_MULTIPLIER = 1
CELERY_BROKER_CONNECTION_RETRY_ON_STARTUP = True
# Sending a task is a courtesy too (the sweeps redo what a lost message left): from the outbox's
# thread, with short timeouts and no retries, so a stalled Redis only delays it.
CELERY_TASK_PUBLISH_RETRY = False
CELERY_BROKER_TRANSPORT_OPTIONS = {"socket_timeout": 2, "socket_connect_timeout": 2}
# Wake-ups, page events and Celery messages leave the request's thread (core/outbox.py); off,
# they are sent at once (the test process, where tests read what was sent right away).
OUTBOX_THREAD = env_bool("OUTBOX_THREAD", True)
CELERY_TIMEZONE = TIME_ZONE
# Sweeps re-find anything a lost Celery message left behind, so none of them is critical alone.
PRESENCE_SWEEP_SECONDS = env_int("PRESENCE_SWEEP_SECONDS", 1, minimum=1)
SWEEP_SECONDS = env_int("SWEEP_SECONDS", 1, minimum=1)
# Webhook deliveries whose retry time came (or whose Celery message was lost) are sent by a sweep.
WEBHOOK_SWEEP_SECONDS = env_int("WEBHOOK_SWEEP_SECONDS", 5, minimum=1)
# Webhooks never reach loopback, private, link-local, multicast, reserved or the server's own
# addresses (webhooks/targets.py) except inside these networks, e.g. 10.20.0.0/16 for the
# hospital's laboratory system: comma-separated, CIDR or single addresses.
WEBHOOK_ALLOWED_NETWORKS = env_list("WEBHOOK_ALLOWED_NETWORKS", [])
for _network in WEBHOOK_ALLOWED_NETWORKS:
    try:
        ipaddress.ip_network(_network, strict=False)
    except ValueError:
        raise ImproperlyConfigured(
            f"WEBHOOK_ALLOWED_NETWORKS: {_network!r} is not a network (use e.g. 10.20.0.0/16)"
        ) from None

# The building's lifts and doors (building/): "sim" drives simulated ones (the demo, tests),
# "mqtt" a building integrator's controller over MQTT (docs/building-devices.md), "none" none.
BUILDING_ADAPTER = env_str("BUILDING_ADAPTER", "sim")
if BUILDING_ADAPTER not in ("sim", "mqtt", "none"):
    raise ImproperlyConfigured("BUILDING_ADAPTER must be sim, mqtt or none")
# The simulated lifts and doors move this many times faster than real ones: the tests' robots
# are simulated faster than real time too (BUILDING_ADAPTER=sim only).
BUILDING_SIM_SPEEDUP = env_int("BUILDING_SIM_SPEEDUP", 1, minimum=1)
# A device silent this long (seconds) is taken out of service.
BUILDING_REPORT_TIMEOUT = env_int("BUILDING_REPORT_TIMEOUT", 10, minimum=1)
BUILDING_MQTT_HOST = env_str("BUILDING_MQTT_HOST", "127.0.0.1")
BUILDING_MQTT_PORT = env_int("BUILDING_MQTT_PORT", 1883, minimum=1)
BUILDING_MQTT_PREFIX = env_str("BUILDING_MQTT_PREFIX", "hospital_delivery/building")
# The VDA 5050 bridge (manage.py vda5050_bridge): the MQTT broker and the topics' first level
# (`<interface>/v2/<manufacturer>/<serialNumber>/<topic>`).
VDA5050_MQTT_HOST = env_str("VDA5050_MQTT_HOST", "127.0.0.1")
VDA5050_MQTT_PORT = env_int("VDA5050_MQTT_PORT", 1883, minimum=1)
VDA5050_INTERFACE = env_str("VDA5050_INTERFACE", "uagv")


def _sweep(task: str, every: float) -> dict:
    return {"task": task, "schedule": every, "options": {"expires": every * 5}}


CELERY_BEAT_SCHEDULE = {
    "robots-presence-sweep": _sweep("robots.tasks.presence_sweep", PRESENCE_SWEEP_SECONDS),
    "resources-lease-sweep": _sweep("resources.tasks.lease_sweep", SWEEP_SECONDS),
    "scheduling-due-sweep": _sweep("scheduling.tasks.due_sweep", SWEEP_SECONDS),
    "scheduling-ack-timeout-sweep": _sweep("scheduling.tasks.ack_timeout_sweep", SWEEP_SECONDS),
    "scheduling-recurring-sweep": _sweep("scheduling.tasks.recurring_sweep", 30),
    "scheduling-unload-timeout-sweep": _sweep("scheduling.tasks.unload_timeout_sweep", 10),
    # Robots whose maintenance time ended, and robots moving without progress.
    "scheduling-robot-watch-sweep": _sweep("scheduling.tasks.robot_watch_sweep", 10),
    "webhooks-send-sweep": _sweep("webhooks.tasks.send_sweep", WEBHOOK_SWEEP_SECONDS),
    # Stores the reports' figures of each settled day (reports/rollups.py); cheap when there
    # is nothing new, and at this interval the watchdog sees it run soon after a start.
    "reports-rollup-sweep": _sweep("reports.tasks.rollup_sweep", 30),
    "building-sweep": _sweep("building.tasks.building_sweep", SWEEP_SECONDS),
    # Old audit entries (audit/services.py): one indexed read when nothing is due, and at this
    # interval the watchdog sees it run soon after a start, as the roll-ups.
    "audit-retention-sweep": _sweep("audit.tasks.retention_sweep", 30),
}

# WARNING by default, for our loggers and the libraries' alike: the run command's terminal (and
# a server's journal) shows what needs a person, not the heartbeats and sweeps behind it. The
# `activity` logger (hospital_delivery/activity.py: deliveries' status changes, alerts) always
# prints at INFO. Times are local times of the process, which Django sets to TIME_ZONE, so every
# process of the run command (which exports TZ to the same zone) logs in the site's zone.
LOG_LEVEL = env_str("LOG_LEVEL", "WARNING").upper()
LOGGING = {
    "version": 1,
    "disable_existing_loggers": False,
    "formatters": {
        "plain": {
            "format": "%(asctime)s %(levelname)s %(name)s: %(message)s",
            "datefmt": "%Y-%m-%d %H:%M:%S%z",
        }
    },
    "handlers": {"console": {"class": "logging.StreamHandler", "formatter": "plain"}},
    "root": {"handlers": ["console"], "level": LOG_LEVEL},
    "loggers": {
        # Celery's own line per task run and per beat tick: the sweeps run every second, so
        # these would flood the log; each sweep logs what it changed instead.
        **{
            name: {"level": "WARNING"}
            for name in ("celery.app.trace", "celery.worker.strategy", "celery.beat")
        },
        "activity": {"level": "DEBUG" if LOG_LEVEL == "DEBUG" else "INFO"},
    },
}
