from django.core.management.base import BaseCommand, CommandError

from robots.models import Robot
from robots.services import robot_token_issue


class Command(BaseCommand):
    help = "Issue a new token for a robot (revoking its old one) and print it once."

    def add_arguments(self, parser):
        parser.add_argument("robot", help="robot code, e.g. R3")

    def handle(self, *args, robot, **options):
        found = Robot.objects.filter(code=robot).first()
        if found is None:
            raise CommandError(f"no robot with code {robot!r}")
        self.stdout.write(robot_token_issue(robot=found))
