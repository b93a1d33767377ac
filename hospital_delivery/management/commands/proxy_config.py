"""Write the nginx configuration that puts every server behind one port (scripts/run.sh)."""

import getpass
import os
import pwd
from pathlib import Path

from django.conf import settings
from django.core.management.base import BaseCommand

from hospital_delivery.proxy import Upstreams, nginx_config


class Command(BaseCommand):
    help = "Write nginx.conf: one port in front of gunicorn and daphne (hospital_delivery/proxy.py)"

    def add_arguments(self, parser):
        parser.add_argument("--listen", default="127.0.0.1:8000", help="where nginx listens")
        parser.add_argument("--web", default="127.0.0.1:8002", help="gunicorn")
        parser.add_argument(
            "--web-woken", default="127.0.0.1:8003", help="gunicorn's socket for woken heartbeats"
        )
        parser.add_argument("--ws", default="127.0.0.1:8001", help="daphne")
        parser.add_argument("--runtime", default="var/nginx", help="pid file and temporary bodies")
        parser.add_argument("--static-root", default=str(settings.STATIC_ROOT))

    def handle(self, *args, **options):
        runtime = Path(options["runtime"]).resolve()
        for part in ("", "body", "proxy", "fastcgi", "uwsgi", "scgi"):
            (runtime / part).mkdir(parents=True, exist_ok=True)
        upstreams = Upstreams(
            listen=options["listen"],
            web=options["web"],
            web_woken=options["web_woken"],
            ws=options["ws"],
            static_root=Path(options["static_root"]).resolve(),
            runtime=runtime,
            # Started as root, nginx would hand its workers to "nobody", who may not read the
            # checkout: they run as the checkout's owner instead.
            user=_owner(runtime) if os.geteuid() == 0 else None,
        )
        (runtime / "nginx.conf").write_text(nginx_config(upstreams))
        self.stdout.write(str(runtime / "nginx.conf"))


def _owner(path: Path) -> str:
    try:
        return pwd.getpwuid(path.stat().st_uid).pw_name
    except KeyError:
        return getpass.getuser()
