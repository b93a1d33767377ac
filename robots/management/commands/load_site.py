from django.core.management.base import BaseCommand, CommandError

from robots.choices import WaypointKind
from robots.models import Site
from robots.sitefile import SiteFileInvalid, site_file_read, site_file_validate, site_load


class Command(BaseCommand):
    help = (
        "Load a site description file (YAML or JSON, robot-protocol.md). The whole file is "
        "checked first; if anything is wrong every problem is listed and nothing is written."
    )

    def add_arguments(self, parser):
        parser.add_argument("file", help="path to a .yaml, .yml or .json site file")
        parser.add_argument(
            "--check", action="store_true", help="only validate the file; write nothing"
        )

    def handle(self, *args, file, check, **options):
        try:
            data = site_file_read(file)
            if check:
                self._check(data, file)
                return
            site = site_load(data=data)
        except OSError as exc:
            raise CommandError(f"cannot read {file}: {exc.strerror or exc}") from None
        except SiteFileInvalid as exc:
            for problem in exc.problems:
                self.stderr.write(problem)
            raise CommandError(
                f"{file}: {len(exc.problems)} problem(s); nothing was loaded"
            ) from None
        self.stdout.write(_summary(site))

    def _check(self, data: dict, file: str) -> None:
        problems = site_file_validate(data)
        if problems:
            raise SiteFileInvalid(problems)
        self.stdout.write(f"{file}: valid site file for site '{data['site']}'")


def _summary(site: Site) -> str:
    verb = "Created" if site.map_version == 1 else "Updated"
    waypoints = site.waypoints.all()
    return (
        f"{verb} site '{site.code}' (map version {site.map_version}): "
        f"{site.floors.count()} floors, {waypoints.count()} waypoints "
        f"({waypoints.filter(kind=WaypointKind.STATION).count()} stations, "
        f"{waypoints.filter(kind=WaypointKind.DOCK).count()} docks), {site.edges.count()} edges, "
        f"{site.resources.count()} resources, {site.robots.count()} robots"
    )
