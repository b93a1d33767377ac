"""The project's WSGI application as the tests' gunicorn serves it.

A transactional test empties the database after itself, and Django then creates the content
types again under new ids. A server process started once for the whole session would keep the
old ids in ContentType's cache, and the audit entries it writes would name a content type that
no longer exists; so each request starts from an empty cache, as a freshly started server would.
"""

from hospital_delivery.wsgi import application as project_application  # sets Django up first

from django.contrib.contenttypes.models import ContentType  # noqa: E402  isort: skip


def application(environ, start_response):
    ContentType.objects.clear_cache()
    return project_application(environ, start_response)
