"""Remove audit entries older than AUDIT_RETENTION_DAYS now (Celery beat runs it daily)."""

from django.core.management.base import BaseCommand
from django.utils import timezone

from audit.services import entries_sweep


class Command(BaseCommand):
    help = "Remove audit entries older than AUDIT_RETENTION_DAYS, recording what was removed."

    def handle(self, *args, **options):
        removed = entries_sweep(now=timezone.now())
        self.stdout.write(f"{removed} audit entries removed")
