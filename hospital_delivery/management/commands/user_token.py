from django.contrib.auth import get_user_model
from django.core.management.base import BaseCommand, CommandError
from django.utils import timezone

from core.access import INTEGRATION, OPERATOR
from hospital_delivery.models import ApiToken


class Command(BaseCommand):
    help = (
        "Issue a new API token for a staff user or a user of the integration group (revoking "
        "the previous one) and print it once; "
        "--list shows who holds a token, --revoke takes a user's token away."
    )

    def add_arguments(self, parser):
        parser.add_argument("username", nargs="?")
        action = parser.add_mutually_exclusive_group()
        action.add_argument(
            "--list",
            dest="list_holders",
            action="store_true",
            help="users holding a token, since when",
        )
        action.add_argument("--revoke", action="store_true", help="revoke the user's token")

    def handle(self, *args, username, list_holders, revoke, **options):
        if list_holders:
            return self._list()
        if not username:
            raise CommandError("name a user (or --list)")
        user = get_user_model().objects.filter(username=username).first()
        if user is None:
            raise CommandError(f"no user named {username!r}")
        if revoke:
            deleted, _ = ApiToken.objects.filter(user=user).delete()
            self.stdout.write(f"revoked {username}'s token" if deleted else f"{username} had none")
            return None
        # The integration group's tokens open the FHIR endpoint only (fhir/, core.access); the
        # operator group's, the fire alarm of their sites (a building management system).
        if not (user.is_staff or user.groups.filter(name__in=[INTEGRATION, OPERATOR]).exists()):
            raise CommandError(
                f"{username!r} is neither a staff user, in the {INTEGRATION} group nor an "
                f"{OPERATOR}; the API serves only them"
            )
        self.stdout.write(ApiToken.issue(user))
        return None

    def _list(self):
        for token in ApiToken.objects.select_related("user").order_by("user__username"):
            issued = timezone.localtime(token.created_at).strftime("%Y-%m-%d %H:%M")
            self.stdout.write(f"{token.user.username}\tissued {issued}")
