"""python manage.py demo_setup: the demo's accounts and the simulated fleet's credentials.

Idempotent; ./scripts/run.sh runs it on every start.

* users: groups `nurse` and `operator`; users `admin` (superuser), `operator` (group operator,
  not staff: no admin and no map editor, as in a hospital) and `nurse` (group nurse). Their
  passwords are generated once, kept in var/demo_logins.json (mode 600) and printed on every run.
* fleet: a new token for every robot of the site, and a new API token for the staff user
  `traffic` (the simulated fleet's request generator), written with the server's URLs and the
  site file to var/fleet.json (mode 600), which `manage.py simulate_fleet` reads. Tokens are
  stored hashed, so they are issued again on each run (the previous ones stop working). The
  demo nurse is given the site's first ward as her unit and a new badge, whose id goes into
  var/fleet.json for the simulated staff of that ward (only its hash is kept by the server).
  With `--vda5050 SHARE`, that share of the robots (the last by code) is declared VDA 5050
  vehicles first (the demo's mixed fleet: simulate_fleet runs them over MQTT).
"""

import json
import os
import secrets
from pathlib import Path

from django.conf import settings
from django.contrib.auth import get_user_model
from django.contrib.auth.models import Group
from django.core.management.base import BaseCommand, CommandError
from django.db import transaction

from building.services import devices_ensure
from hospital_delivery.models import ApiToken
from robots.choices import RobotProtocol, WaypointKind
from robots.models import Robot, Site, SiteMembership, Waypoint
from robots.services import membership_badge_set, robot_protocol_declare, robot_token_issue
from robots.sitefile import SiteFileInvalid, site_file_read

GROUPS = ("nurse", "operator")
# username -> (group, staff, superuser, what it is for)
DEMO_USERS = {
    "admin": (None, True, True, "superuser: /admin/"),
    "operator": ("operator", False, False, "operator: the fleet, every task, pause/resume"),
    "nurse": ("nurse", False, False, "nurse: order deliveries and follow them"),
}
TRAFFIC_USER = "traffic"
VDA5050_MANUFACTURER = "robotsim"  # the simulated VDA 5050 vehicles (robotsim/vda5050.py)


def write_private(path: Path, data: dict) -> None:
    """Write JSON readable by this user only (mode 600), replacing the file atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "w", encoding="utf-8") as file:
        json.dump(data, file, indent=2)
        file.write("\n")
    os.chmod(temporary, 0o600)
    temporary.replace(path)


class Command(BaseCommand):
    help = "Create the demo users (printing their logins) and the simulated fleet's tokens."

    def add_arguments(self, parser):
        parser.add_argument("--only", choices=["users", "fleet"], help="do only this part")
        parser.add_argument("--site-file", default="sites/eulji.yaml")
        parser.add_argument("--server-url", default="http://127.0.0.1:8000")
        parser.add_argument("--ws-url", default="ws://127.0.0.1:8001")
        parser.add_argument("--logins", default="var/demo_logins.json")
        parser.add_argument("--fleet-file", default="var/fleet.json")
        parser.add_argument(
            "--vda5050",
            type=float,
            help="share (0..1) of the site's robots, the last by code, declared VDA 5050 "
            "vehicles (manufacturer robotsim, serial number their code); the rest heartbeat",
        )

    def handle(self, *args, only=None, **options):
        if only in (None, "users"):
            self._users(Path(options["logins"]))
            self._memberships(options["site_file"])
        if only in (None, "fleet"):
            self._fleet(options)

    # --- Users --------------------------------------------------------------------------

    @transaction.atomic
    def _users(self, logins_path: Path) -> None:
        groups = {name: Group.objects.get_or_create(name=name)[0] for name in GROUPS}
        logins = self._read_logins(logins_path)
        notes = {}
        for username, (group, staff, superuser, _purpose) in DEMO_USERS.items():
            password = logins.get(username) or secrets.token_urlsafe(9)
            notes[username] = self._user(username, password, groups.get(group), staff, superuser)
            logins[username] = password
        write_private(logins_path, logins)
        self.stdout.write(f"Demo logins (kept in {logins_path}):")
        for username, (_group, _staff, _superuser, purpose) in DEMO_USERS.items():
            line = f"  {username:<9} {logins[username]:<14} {purpose}{notes[username]}"
            self.stdout.write(line)

    def _read_logins(self, path: Path) -> dict:
        if not path.exists():
            return {}
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except ValueError as exc:
            raise CommandError(f"{path} is not JSON ({exc}); remove it to start over") from None

    def _user(self, username, password, group, staff, superuser) -> str:
        """Create the user if missing; a note if its password was changed since."""
        User = get_user_model()
        user = User.objects.filter(username=username).first()
        note = ""
        if user is None:
            user = User.objects.create_user(username=username, password=password)
        elif not user.check_password(password):
            note = " (password changed since; not reset)"
        user.is_staff, user.is_superuser = staff, superuser
        user.save(update_fields=["is_staff", "is_superuser"])
        if group is not None:
            user.groups.add(group)
        return note

    def _memberships(self, site_file: str) -> None:
        """The demo users work at the demo site (when it is loaded)."""
        try:
            code = site_file_read(site_file)["site"]
        except (OSError, SiteFileInvalid, KeyError):
            return
        site = Site.objects.filter(code=code).first()
        users = get_user_model().objects.filter(username__in=DEMO_USERS)
        for user in users if site else ():
            SiteMembership.objects.get_or_create(user=user, site=site)
        if site:  # the lifts and doors (simulated by default) show on the fleet page at once
            devices_ensure(site=site)

    # --- Fleet --------------------------------------------------------------------------

    @transaction.atomic
    def _fleet(self, options) -> None:
        site_file = options["site_file"]
        try:
            code = site_file_read(site_file)["site"]
        except (OSError, SiteFileInvalid, KeyError) as exc:
            raise CommandError(f"{site_file}: {exc}") from None
        site = Site.objects.filter(code=code).first()
        if site is None:
            raise CommandError(f"site {code!r} is not loaded: manage.py load_site {site_file}")
        rows = list(Robot.objects.filter(site=site).select_related("dock").order_by("code"))
        if options.get("vda5050") is not None:
            self._vda5050_declare(rows, options["vda5050"])
        robots = [
            {
                "code": robot.code,
                "token": robot_token_issue(robot=robot),
                "dock": robot.dock.code,
                "protocol": robot.protocol,
                "manufacturer": robot.manufacturer,
                "serial_number": robot.serial_number,
            }
            for robot in rows
        ]
        fleet = {
            "server_url": options["server_url"],
            "ws_url": options["ws_url"],
            "site_file": site_file,
            "robots": robots,
            "traffic_token": ApiToken.issue(self._traffic_user()),
            "badges": self._nurse_badge(site),
            "mqtt": {
                "host": settings.VDA5050_MQTT_HOST,
                "port": settings.VDA5050_MQTT_PORT,
                "interface": settings.VDA5050_INTERFACE,
            },
        }
        path = Path(options["fleet_file"])
        write_private(path, fleet)
        codes = ", ".join(robot["code"] for robot in robots) or "none"
        self.stdout.write(f"Tokens for robots {codes} and the traffic user's API token: {path}")

    def _nurse_badge(self, site: Site) -> dict[str, str]:
        """The demo nurse works on the site's first ward, with a new badge each run (only its
        hash is kept): the simulated staff there open secure deliveries with it too."""
        membership = SiteMembership.objects.filter(user__username="nurse", site=site).first()
        wards = Waypoint.objects.filter(
            site=site, kind=WaypointKind.STATION, code__icontains="ward"
        )
        ward = wards.order_by("code").first()
        if membership is None or ward is None:
            return {}
        badge = ":".join(secrets.token_hex(1).upper() for _ in range(7))
        membership.unit = ward
        membership.save(update_fields=["unit"])
        membership_badge_set(membership=membership, badge=badge)
        return {ward.code: badge}

    def _vda5050_declare(self, robots: list[Robot], share: float) -> None:
        if not 0 <= share <= 1:
            raise CommandError(f"--vda5050: a share from 0 to 1, not {share:g}")
        count = round(share * len(robots))
        for n, robot in enumerate(robots):
            if n >= len(robots) - count:
                robot_protocol_declare(
                    robot=robot,
                    protocol=RobotProtocol.VDA5050,
                    manufacturer=VDA5050_MANUFACTURER,
                    serial_number=robot.code,
                )
            else:
                robot_protocol_declare(robot=robot, protocol=RobotProtocol.HEARTBEAT)

    def _traffic_user(self):
        User = get_user_model()
        user, created = User.objects.get_or_create(
            username=TRAFFIC_USER, defaults={"is_staff": True}
        )
        if created:
            user.set_unusable_password()
            user.save(update_fields=["password"])
        return user
