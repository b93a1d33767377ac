"""The one settings module. Every value a deployment may change comes from the environment.

Bad values stop the process at start-up (see env.py) instead of surfacing later.
"""

from pathlib import Path

import dj_database_url
from django.core.exceptions import ImproperlyConfigured

from hospital_delivery.env import env_bool, env_int, env_list, env_str

BASE_DIR = Path(__file__).resolve().parent.parent

DEBUG = env_bool("DEBUG", False)
SECRET_KEY = env_str("SECRET_KEY", "")
if not SECRET_KEY:
    if not DEBUG:
        raise ImproperlyConfigured("SECRET_KEY must be set when DEBUG is off")
    SECRET_KEY = "insecure-development-key-do-not-use-in-production"
ALLOWED_HOSTS = env_list("ALLOWED_HOSTS", ["localhost", "127.0.0.1", "[::1]"])
CSRF_TRUSTED_ORIGINS = env_list("CSRF_TRUSTED_ORIGINS", [])

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
    "channels",
    # Components, lowest layer first (pyproject.toml, [tool.importlinter]).
    "robots",
    "boards",
    "resources",
    "scheduling",
    "ui",
    "hospital_delivery",
]

MIDDLEWARE = [
    "django.middleware.security.SecurityMiddleware",
    "whitenoise.middleware.WhiteNoiseMiddleware",
    "django.contrib.sessions.middleware.SessionMiddleware",
    "django.middleware.common.CommonMiddleware",
    "django.middleware.csrf.CsrfViewMiddleware",
    "django.contrib.auth.middleware.AuthenticationMiddleware",
    "django.contrib.messages.middleware.MessageMiddleware",
    "django.middleware.clickjacking.XFrameOptionsMiddleware",
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

REDIS_URL = env_str("REDIS_URL", "redis://127.0.0.1:6379/0")

# Where the pages' websockets connect. Pages are served by gunicorn (HTTP), websockets by daphne
# on another port (Procfile), so by default a page connects to ws(s)://<its own host>:PORT_WS.
# WEBSOCKET_URL (e.g. wss://fleet.example.org, behind a proxy) overrides that.
WEBSOCKET_URL = env_str("WEBSOCKET_URL", "")
WEBSOCKET_PORT = env_int("WEBSOCKET_PORT", env_int("PORT_WS", 8001, minimum=1), minimum=1)

CACHES = {
    "default": {"BACKEND": "django.core.cache.backends.locmem.LocMemCache"},
}

AUTH_PASSWORD_VALIDATORS = [
    {"NAME": "django.contrib.auth.password_validation.MinimumLengthValidator"},
    {"NAME": "django.contrib.auth.password_validation.CommonPasswordValidator"},
]
LOGIN_URL = "login"
LOGIN_REDIRECT_URL = "/"
LOGOUT_REDIRECT_URL = "login"

LANGUAGE_CODE = "en-us"
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
    "DEFAULT_SCHEMA_CLASS": "drf_spectacular.openapi.AutoSchema",
    "EXCEPTION_HANDLER": "core.errors.exception_handler",
    "DEFAULT_PAGINATION_CLASS": "rest_framework.pagination.LimitOffsetPagination",
    "PAGE_SIZE": 100,
}
SPECTACULAR_SETTINGS = {
    "TITLE": "hospital_delivery API",
    "DESCRIPTION": "Fleet server for hospital delivery robots: the robot heartbeat and "
    "message board (protocol v1), the device catalog and delivery tasks.",
    "VERSION": "1",
    "SERVE_INCLUDE_SCHEMA": False,
    "COMPONENT_SPLIT_REQUEST": True,
}

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

# Robot heartbeat bodies above this size are refused with 413 (protocol v1).
HEARTBEAT_MAX_BYTES = 64 * 1024

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
CELERY_TIMEZONE = TIME_ZONE
# Sweeps re-find anything a lost Celery message left behind, so none of them is critical alone.
PRESENCE_SWEEP_SECONDS = env_int("PRESENCE_SWEEP_SECONDS", 1, minimum=1)
SWEEP_SECONDS = env_int("SWEEP_SECONDS", 1, minimum=1)


def _sweep(task: str, every: float) -> dict:
    return {"task": task, "schedule": every, "options": {"expires": every * 5}}


CELERY_BEAT_SCHEDULE = {
    "robots-presence-sweep": _sweep("robots.tasks.presence_sweep", PRESENCE_SWEEP_SECONDS),
    "resources-lease-sweep": _sweep("resources.tasks.lease_sweep", SWEEP_SECONDS),
    "scheduling-due-sweep": _sweep("scheduling.tasks.due_sweep", SWEEP_SECONDS),
    "scheduling-ack-timeout-sweep": _sweep("scheduling.tasks.ack_timeout_sweep", SWEEP_SECONDS),
    "scheduling-recurring-sweep": _sweep("scheduling.tasks.recurring_sweep", 30),
}

LOG_LEVEL = env_str("LOG_LEVEL", "INFO")
LOGGING = {
    "version": 1,
    "disable_existing_loggers": False,
    "formatters": {"plain": {"format": "%(asctime)s %(levelname)s %(name)s: %(message)s"}},
    "handlers": {"console": {"class": "logging.StreamHandler", "formatter": "plain"}},
    "root": {"handlers": ["console"], "level": LOG_LEVEL},
}
