"""python manage.py simulate_fleet: run simulated robots (robotsim) against a running server.

The robots know what real ones would: the site FILE (their map), their token and the server's
URLs, read from the fleet file that `manage.py demo_setup` writes (var/fleet.json). They speak
HTTP (and the push websocket) only; this command never touches the database.

Robots the fleet file says speak VDA 5050 (demo_setup --vda5050) run as simulated VDA 5050
vehicles instead (robotsim/vda5050.py): MQTT to the broker the fleet file names, where the
VDA 5050 bridge (manage.py vda5050_bridge) makes them members of the fleet.
"""

import dataclasses
import math
import random
import signal
import threading

from django.core.management.base import BaseCommand, CommandError

from robots.router import site_map_from_file
from robots.sitefile import SiteFileInvalid, site_file_read
from robotsim.fleet import Fleet, FleetConfig, RobotSpec, fleet_file_read
from robotsim.network import NetworkModel
from robotsim.simulator import Behaviour
from robotsim.traffic import HttpMapSource
from robotsim.vda5050 import VdaVehicle


def _pair(text: str) -> tuple[float, float]:
    low, _, high = text.partition(",")
    return float(low), float(high or low)


def _check_options(options) -> None:
    if options["speedup"] <= 0:
        raise CommandError(f"--speedup: must be above 0, not {options['speedup']:g}")
    if options["traffic"] < 0:
        raise CommandError(f"--traffic: must be 0 or more, not {options['traffic']:g}")
    if not 0 <= options["secure_share"] <= 1:
        raise CommandError(f"--secure-share: must be 0 to 1, not {options['secure_share']:g}")
    if options["vda5050"] is not None and not 0 <= options["vda5050"] <= 1:
        raise CommandError(f"--vda5050: must be 0 to 1, not {options['vda5050']:g}")
    low, high = options["staff_delay"]
    if not 0 <= low <= high:
        raise CommandError(f"--staff-delay: want 0 <= MIN <= MAX, not {low:g},{high:g}")


class Command(BaseCommand):
    help = "Run simulated delivery robots (and optional request traffic) against the server."

    def add_arguments(self, parser):
        parser.add_argument("--fleet", default="var/fleet.json", help="written by demo_setup")
        parser.add_argument("--site", help="site file (default: the fleet file's)")
        parser.add_argument("--server", help="server URL (default: the fleet file's)")
        parser.add_argument("--ws", help="websocket base URL for the push channel")
        parser.add_argument("--no-push", action="store_true", help="heartbeats only")
        parser.add_argument(
            "--robots", help="how many of the fleet file's robots (4), or codes: R1,R3"
        )
        parser.add_argument(
            "--speedup", type=float, default=1.0, help="simulated seconds per real second"
        )
        parser.add_argument("--request-loss", type=float, default=0.0, help="0..1")
        parser.add_argument("--response-loss", type=float, default=0.0, help="0..1")
        parser.add_argument("--duplicate", type=float, default=0.0, help="0..1, sent again later")
        parser.add_argument("--delay", type=_pair, default=(0.0, 0.0), help="MIN,MAX seconds")
        parser.add_argument(
            "--dead-zone",
            action="append",
            default=[],
            help="waypoint without network (AP handover)",
        )
        parser.add_argument(
            "--staff-delay", type=_pair, default=(15.0, 60.0), help="MIN,MAX simulated seconds"
        )
        parser.add_argument(
            "--traffic", type=float, default=0.0, help="random deliveries per simulated hour"
        )
        parser.add_argument(
            "--secure-share",
            type=float,
            default=0.3,
            help="share of random medication deliveries that are secure (locked, PIN)",
        )
        parser.add_argument(
            "--vda5050",
            type=float,
            default=None,
            help="share (0..1) of the robots, the last ones, to run as VDA 5050 vehicles over "
            "MQTT; they must be declared so (demo_setup --vda5050). Default: as the fleet "
            "file says",
        )
        parser.add_argument(
            "--cabin-network",
            action="store_true",
            help="the lift cabins have network: robots hear their board while riding",
        )
        parser.add_argument("--seed", type=int, default=None)
        parser.add_argument("--duration", type=float, help="stop after this many real seconds")
        parser.add_argument(
            "--status-every", type=float, default=30.0, help="real seconds between status lines"
        )

    def handle(self, *args, **options):
        config = self._config(options)
        vehicles = self._vehicles(config, options)
        heartbeat = tuple(r for r in config.robots if r.code not in {v[0] for v in vehicles})
        config = dataclasses.replace(config, robots=heartbeat)
        try:
            fleet = Fleet(config)
        except ValueError as exc:  # a dead zone where robots wait, traffic without a token
            raise CommandError(str(exc)) from None
        stop = threading.Event()
        previous = {
            s: signal.signal(s, lambda *_: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)
        }
        if options["duration"]:
            timer = threading.Timer(options["duration"], stop.set)
            timer.daemon = True
            timer.start()
        self._banner(config)
        started = [vehicle for _, vehicle in vehicles]
        for vehicle in started:
            vehicle.start()
        if started:
            first = started[0]
            self.stdout.write(
                f"VDA 5050 vehicles {', '.join(code for code, _ in vehicles)} over MQTT "
                f"({first.host}:{first.port}, topics {first.prefix.split('/')[0]}/v2/...)"
            )
        try:
            fleet.run(stop, status_every=options["status_every"])
        finally:
            for vehicle in started:
                vehicle.stop()
            for signum, handler in previous.items():
                signal.signal(signum, handler)
        self.stdout.write(f"fleet stopped; network: {fleet.network_stats()}")

    def _config(self, options) -> FleetConfig:
        _check_options(options)
        try:
            file = fleet_file_read(options["fleet"])
        except (OSError, ValueError) as exc:
            raise CommandError(f"{options['fleet']}: {exc} (run manage.py demo_setup)") from None
        site_path = options["site"] or file["site_file"]
        try:
            site = site_file_read(site_path)
        except (OSError, SiteFileInvalid) as exc:
            raise CommandError(f"{site_path}: {exc}") from None
        ws_url = None if options["no_push"] else options["ws"] or file.get("ws_url")
        seed = options["seed"] if options["seed"] is not None else random.randrange(2**31)
        try:
            network = NetworkModel(
                request_loss=options["request_loss"],
                response_loss=options["response_loss"],
                duplicate=options["duplicate"],
                delay=options["delay"],
                dead_zones=frozenset(options["dead_zone"]),
            )
        except ValueError as exc:
            raise CommandError(str(exc)) from None
        return FleetConfig(
            server_url=options["server"] or file["server_url"],
            ws_url=ws_url,
            site=site,
            robots=self._robots(file, options["robots"]),
            speedup=options["speedup"],
            network=network,
            behaviour=Behaviour.for_site(
                site, staff_delay=options["staff_delay"], cabin_network=options["cabin_network"]
            ),
            seed=seed,
            traffic_rate=options["traffic"],
            traffic_token=file.get("traffic_token"),
            secure_share=options["secure_share"],
            badges=dict(file.get("badges", {})),
            map_source=self._maps(file, options, site),
        )

    def _maps(self, file: dict, options, site: dict) -> HttpMapSource | None:
        """New map versions, fetched over the API with the fleet file's staff token."""
        token = file.get("traffic_token")
        server = options["server"] or file["server_url"]
        return HttpMapSource(server, token, site["site"]) if token else None

    def _vehicles(self, config: FleetConfig, options) -> list[tuple[str, VdaVehicle]]:
        """(code, vehicle) of the robots to run as VDA 5050 vehicles."""
        file = fleet_file_read(options["fleet"])
        entries = {r["code"]: r for r in file["robots"]}
        codes = [r.code for r in config.robots]
        if options["vda5050"] is None:
            chosen = [c for c in codes if entries[c].get("protocol") == "vda5050"]
        else:
            chosen = codes[len(codes) - math.floor(options["vda5050"] * len(codes) + 0.5) :]
        undeclared = [c for c in chosen if not entries[c].get("serial_number")]
        if undeclared:
            raise CommandError(
                f"not VDA 5050 robots on the server: {', '.join(undeclared)} "
                "(manage.py demo_setup --vda5050 SHARE declares them)"
            )
        mqtt = file.get("mqtt", {})
        site_map = site_map_from_file(config.site)
        rng = random.Random(config.seed)
        return [
            (
                code,
                VdaVehicle(
                    site_map=site_map,
                    manufacturer=entries[code]["manufacturer"],
                    serial_number=entries[code]["serial_number"],
                    dock=entries[code]["dock"],
                    host=mqtt.get("host", "127.0.0.1"),
                    port=mqtt.get("port", 1883),
                    interface=mqtt.get("interface", "uagv"),
                    speedup=config.speedup,
                    staff_delay=options["staff_delay"],
                    rng=random.Random(rng.random()),
                ),
            )
            for code in chosen
        ]

    def _robots(self, file: dict, wanted: str | None) -> tuple[RobotSpec, ...]:
        robots = [RobotSpec(r["code"], r["token"], r["dock"]) for r in file["robots"]]
        if wanted and wanted.isdigit():
            robots = robots[: int(wanted)]
        elif wanted:
            codes = wanted.split(",")
            unknown = set(codes) - {r.code for r in robots}
            if unknown:
                raise CommandError(f"not in the fleet file: {', '.join(sorted(unknown))}")
            robots = [r for r in robots if r.code in codes]
        if not robots:
            raise CommandError("no robots to simulate")
        return tuple(robots)

    def _banner(self, config: FleetConfig) -> None:
        codes = ", ".join(r.code for r in config.robots)
        push = f"push channel {config.ws_url}" if config.ws_url else "heartbeats only"
        traffic = f"{config.traffic_rate:g} random deliveries per simulated hour"
        self.stdout.write(
            f"Simulated fleet {codes} on {config.site['site']} against {config.server_url} "
            f"({push}); time x{config.speedup:g}: one real minute is {config.speedup:g} "
            f"simulated minutes; {traffic if config.traffic_rate else 'no traffic'}; "
            f"seed {config.seed}. Ctrl-C stops it."
        )
