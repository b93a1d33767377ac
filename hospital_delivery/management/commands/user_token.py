from django.contrib.auth import get_user_model
from django.core.management.base import BaseCommand, CommandError

from hospital_delivery.models import ApiToken


class Command(BaseCommand):
    help = "Issue a new API token for a staff user (revoking the previous one) and print it once."

    def add_arguments(self, parser):
        parser.add_argument("username")

    def handle(self, *args, username, **options):
        user = get_user_model().objects.filter(username=username).first()
        if user is None:
            raise CommandError(f"no user named {username!r}")
        if not user.is_staff:
            raise CommandError(f"{username!r} is not a staff user; the API serves staff only")
        self.stdout.write(ApiToken.issue(user))
