"""manage.py reports_seed [--site eulji] [--deliveries 100000] [--days 365]: a generated
history for the reports page (reports/seed.py). Adds to what is there; use a throwaway
database (bench/reports.py does)."""

from django.core.management.base import BaseCommand, CommandError
from django.utils import timezone

from reports.seed import history_seed
from robots.models import Site


class Command(BaseCommand):
    help = "Generate a history of deliveries, robot activity, leases and alerts for the reports."

    def add_arguments(self, parser):
        parser.add_argument("--site", help="site code (default: the first site)")
        parser.add_argument("--deliveries", type=int, default=100_000)
        parser.add_argument("--days", type=int, default=365)
        parser.add_argument("--seed", type=int, default=1)

    def handle(self, *args, site=None, deliveries, days, seed, **options):
        if deliveries < 1 or days < 1:
            raise CommandError("--deliveries and --days must be at least 1")
        chosen = Site.objects.filter(code=site).first() if site else Site.objects.first()
        if chosen is None:
            raise CommandError(f"no site {site or ''} (manage.py load_site FILE first)")
        try:
            seeded = history_seed(
                site=chosen, deliveries=deliveries, days=days, end=timezone.now(), seed=seed
            )
        except ValueError as exc:
            raise CommandError(str(exc)) from None
        self.stdout.write(
            f"{chosen.code}: {seeded.deliveries} deliveries over {days} days, "
            f"{seeded.transitions} transitions, {seeded.activities} robot activities, "
            f"{seeded.leases} leases, {seeded.alerts} alerts"
        )
