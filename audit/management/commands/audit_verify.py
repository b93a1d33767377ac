"""Check the audit trail's hash chain; exit 1 naming the first entry that does not match."""

from django.core.management.base import BaseCommand, CommandError

from audit.verification import chain_verify


class Command(BaseCommand):
    help = "Check the audit trail's hash chain and name the first entry that does not match."

    def handle(self, *args, **options):
        verdict = chain_verify()
        if verdict.first_bad_id is not None:
            raise CommandError(
                f"audit entry #{verdict.first_bad_id} {verdict.reason} "
                f"({verdict.checked} entries before it verified)"
            )
        if not verdict.ok:
            raise CommandError(f"the audit trail is cut short: {verdict.reason}")
        self.stdout.write(
            f"{verdict.checked} audit entries verified; the newest hash is "
            f"{verdict.last_hash or '(none)'}"
        )
