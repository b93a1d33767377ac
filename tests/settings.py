"""The project's settings for the tests, with one change: on PostgreSQL, a backend that empties
the database faster between transactional tests (tests/postgresql/base.py). Servers the tests
start in other processes inherit these settings; they never empty the database."""

from hospital_delivery.settings import *  # noqa: F403
from hospital_delivery.settings import DATABASES

if DATABASES["default"]["ENGINE"] == "django.db.backends.postgresql":
    DATABASES["default"]["ENGINE"] = "tests.postgresql"
