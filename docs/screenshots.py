"""The screenshots the documentation shows, made from the real pages: docs/images/*.png

    .venv/bin/python docs/screenshots.py

Runs on a throwaway SQLite database: migrates it, loads sites/eulji.yaml, generates a month of
history for the reports (reports/seed.py), starts gunicorn and daphne as the Procfile does, puts
the four robots around the hospital by heartbeats over HTTP (R2 rides the elevator, R3 waits
for it, R4 holds the 6th floor's narrow corridor), orders deliveries through the scheduling
services, and photographs the pages with Debian's Chromium (CHROMIUM_PATH, default
/usr/bin/chromium) as a nurse, an operator and an administrator would see them. Needs Redis
(REDIS_URL, default the local one) for the pages' live connection. Leaves nothing behind but
the PNG files; run it after changing a page the documentation shows (CONTRIBUTING.md).
"""

import itertools
import os
import shutil
import sys
import tempfile
import uuid
from datetime import UTC, datetime, timedelta
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "docs" / "images"
PASSWORD = "screenshots-only"


def main() -> None:
    workdir = Path(tempfile.mkdtemp(prefix="hd-screenshots-"))
    os.environ.update(
        {
            "DJANGO_SETTINGS_MODULE": "hospital_delivery.settings",
            "DATABASE_URL": f"sqlite:///{workdir / 'db.sqlite3'}",
            "SECRET_KEY": "screenshots-only",
            "CHANNELS_PREFIX": f"hd-screenshots-{uuid.uuid4().hex[:8]}",
            "CELERY_QUEUE": f"hd-screenshots-{uuid.uuid4().hex[:8]}",  # no worker: nothing runs
            "DEBUG": "false",
        }
    )
    sys.path.insert(0, str(REPO))
    import django

    django.setup()
    from django.core.management import call_command

    from tests import servers

    try:
        call_command("migrate", verbosity=0)
        call_command("load_site", str(REPO / "sites" / "eulji.yaml"))
        history()
        with servers.daphne() as ws, servers.gunicorn(env={"WEBSOCKET_URL": ws.url}) as http:
            robots = scene(http)
            photograph(http, robots)
    finally:
        from hospital_delivery.celery import app

        servers.celery_queue_delete(app, os.environ["CELERY_QUEUE"])
        sweeps_fresh(forget=True)
        shutil.rmtree(workdir, ignore_errors=True)


class Robot:
    """A robot speaking protocol v1 over HTTP; it acks what it received at its next heartbeat."""

    def __init__(self, base_url: str, code: str):
        import requests

        from robots.models import Robot as RobotRow
        from robots.services import robot_token_issue

        self.code = code
        self.url = f"{base_url}/api/v1/robots/{code}/heartbeat"
        token = robot_token_issue(robot=RobotRow.objects.get(code=code))
        self.session = requests.Session()
        self.session.headers["Authorization"] = f"Bearer {token}"
        self.seq, self.acks, self.state = 0, [], {}
        self.events = itertools.count(1)

    def beat(self, events=(), requests=(), **state) -> dict:
        self.state = {"plan_version": 0, "errors": [], "load": 0, **self.state, **state}
        self.seq += 1
        body = {
            "boot_id": f"{self.code}-boot",
            "seq": self.seq,
            "sent_at": datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z"),
            "state": self.state,
            "events": [{"id": f"{self.code}-e{next(self.events)}", **e} for e in events],
            "acks": self.acks,
            "requests": list(requests),
        }
        reply = self.session.post(self.url, json=body, timeout=30)
        reply.raise_for_status()
        messages = reply.json()["messages"]
        self.acks = [message["id"] for message in messages]
        plans = [message for message in messages if message["type"] == "plan"]
        if plans:
            self.state["plan_version"] = plans[-1]["plan_version"]
        return reply.json()


def order(site, user, pickups, dropoffs, contents, **fields):
    from robots.models import Waypoint
    from scheduling.services import task_request

    stations = {wp.code: wp for wp in Waypoint.objects.filter(site=site)}
    return task_request(
        site=site,
        requester=user,
        pickups=[stations[code] for code in pickups],
        dropoffs=[stations[code] for code in dropoffs],
        contents=contents,
        **fields,
    )


def allocate(task) -> str:
    from scheduling.models import Task
    from scheduling.services import task_allocate

    task_allocate(task_id=task.pk)
    robot = Task.objects.get(pk=task.pk).robot
    return robot.code if robot else "nobody"


def history() -> None:
    """A month of deliveries before today, for the reports page; its alerts long acknowledged."""
    from django.utils import timezone

    from reports.seed import history_seed
    from robots.models import Alert, Site

    today = timezone.localtime().replace(hour=0, minute=0, second=0, microsecond=0)
    history_seed(site=Site.objects.get(code="eulji"), deliveries=900, days=30, end=today)
    Alert.objects.update(acknowledged_at=today)


def scene(http: str) -> dict:
    """Four robots at work on a weekday morning at Eulji University Hospital."""
    from django.contrib.auth.models import Group, User
    from django.utils import timezone

    from robots.models import Robot as RobotRow
    from robots.models import Site, SiteMembership
    from scheduling.services import robot_action

    site = Site.objects.get(code="eulji")
    nurse = User.objects.create_user("minji", password=PASSWORD, first_name="Minji")
    nurse.groups.add(Group.objects.get(name="nurse"))
    operator = User.objects.create_user("jisoo", password=PASSWORD, first_name="Jisoo")
    operator.last_name = "Park"
    operator.save()
    operator.groups.add(Group.objects.get(name="operator"))
    for user in (nurse, operator):
        SiteMembership.objects.create(user=user, site=site)
    User.objects.create_superuser("hana", password=PASSWORD, first_name="Hana")
    r1, r2, r3, r4 = (Robot(http, code) for code in ("R1", "R2", "R3", "R4"))

    # R3 brings sterile kits to the operating theatre, then fails at the laboratory's door.
    r3.beat(status="idle", floor="2F", waypoint="2F-SUPPLY", x=74, y=20, battery=0.47)
    kits = order(
        site,
        nurse,
        ["2F-SUPPLY"],
        ["3F-OR"],
        "Sterile kits",
        sender="Central supply",
        receiver="Theatre nurse Yoon",
    )
    allocate(kits)
    r3.beat(events=[{"type": "loaded", "task": kits.code, "stop": 0}], load=1)
    r3.beat(
        events=[
            {"type": "unloaded", "task": kits.code, "stop": 1},
            {"type": "task_completed", "task": kits.code},
        ],
        load=0,
    )
    swabs = order(
        site,
        nurse,
        ["2F-SUPPLY"],
        ["2F-LAB-DROP"],
        "Swab kits",
        sender="Central supply",
        receiver="Laboratory",
    )
    allocate(swabs)
    r3.beat()
    r3.beat(
        events=[
            {
                "type": "task_failed",
                "task": swabs.code,
                "reason": "automatic door DOOR-2F-LAB did not open",
            }
        ]
    )

    # R1 picks up blood samples at ward 6A: the paper's trial run, 6F to the 2F laboratory.
    r1.beat(status="idle", floor="6F", waypoint="6F-WARD-A", x=8, y=20, battery=0.81)
    blood = order(
        site,
        nurse,
        ["6F-WARD-A"],
        ["2F-LAB-DROP"],
        "Blood samples",
        sender="Nurse Minji Kim, 6A",
        receiver="Laboratory sample reception",
        priority="urgent",
    )
    allocate(blood)
    r1.beat(events=[{"type": "loaded", "task": blood.code, "stop": 0}], load=1)
    robot_action(robot=RobotRow.objects.get(code="R1"), action="pause", by=operator)
    r1.beat(status="moving", waypoint="6F-HALL-W", x=16, y=12, heading=0.0)
    r1.beat(status="paused")  # a bed was being wheeled through the hall
    robot_action(robot=RobotRow.objects.get(code="R1"), action="resume", by=operator)
    r1.beat()
    r1.beat(status="moving", x=24)

    # R4 brings medication to ward 6B, inside the narrow corridor it may only pass alone.
    r4.beat(status="idle", floor="1F", waypoint="1F-PHARM", x=8, y=20, battery=0.92)
    medication = order(
        site,
        nurse,
        ["1F-PHARM"],
        ["6F-WARD-B"],
        "Medication (antibiotics)",
        sender="Pharmacy",
        receiver="Nurse Lee, 6B",
    )
    allocate(medication)
    r4.beat(events=[{"type": "loaded", "task": medication.code, "stop": 0}], load=1)
    r4.beat(
        status="waiting_resource",
        floor="6F",
        waypoint="6F-CORR-W",
        x=52,
        y=12,
        requests=[{"id": "r4-q1", "type": "acquire", "resource": "CORR-6F"}],
    )
    r4.beat(
        status="in_resource",
        waypoint="6F-CORR-MID",
        x=63.5,
        y=12,
        events=[{"type": "resource_entered", "resource": "CORR-6F"}],
    )

    # R2 rides the elevator down from the 9th floor; R3 waits for it on the 6th.
    r2.beat(
        status="waiting_resource",
        floor="9F",
        waypoint="9F-ELEV-A-WAIT",
        x=40,
        y=4,
        battery=0.64,
        requests=[{"id": "r2-q1", "type": "acquire", "resource": "ELEV-A", "to_floor": "2F"}],
    )
    r2.beat(
        status="in_resource",
        floor="7F",
        waypoint="7F-ELEV-A-WAIT",
        x=40,
        y=4,
        events=[{"type": "resource_entered", "resource": "ELEV-A"}],
    )
    results = order(
        site,
        nurse,
        ["2F-LAB-PICKUP"],
        ["9F-WARD-A", "10F-WARD-B"],
        "Test results",
        sender="Laboratory",
        receiver="Wards 9A and 10B",
    )
    allocate(results)
    r2.beat()
    r3.beat(
        status="waiting_resource",
        floor="6F",
        waypoint="6F-ELEV-A-WAIT",
        x=40,
        y=4,
        requests=[{"id": "r3-q1", "type": "acquire", "resource": "ELEV-A", "to_floor": "15F"}],
    )

    # Later today, every day, and one the allocator has yet to place.
    later = timezone.now() + timedelta(hours=2)
    order(
        site,
        nurse,
        ["2F-SUPPLY"],
        ["14F-WARD-A"],
        "Clean linen",
        sender="Central supply",
        receiver="Ward 14A",
        requested_time=later,
    )
    order(
        site,
        nurse,
        ["13F-WARD-A"],
        ["2F-LAB-DROP"],
        "Morning round samples",
        sender="Ward 13A",
        receiver="Laboratory",
        repeat={"times": ["06:30", "18:30"]},
    )
    order(
        site,
        operator,
        ["3F-ICU"],
        ["3F-OR"],
        "Infusion pump",
        sender="ICU",
        receiver="Operating theatre",
        priority="urgent",
    )
    for _ in range(2):  # every robot acks what it received
        for robot in (r1, r2, r3, r4):
            robot.beat()
    return {"R1": r1, "blood": blood.code}


def sweeps_fresh(forget: bool = False) -> None:
    """No Celery beat runs here: record every sweep as just run, so that the pages show a healthy
    server rather than the banner of stopped sweeps (or, with `forget`, remove those records)."""
    from core.redisclient import redis_client
    from core.watchdog import _key, _sweeps, sweep_record

    for name in _sweeps():
        if forget:
            redis_client().delete(_key(name))
        else:
            sweep_record(name)


def photograph(http: str, robots: dict) -> None:
    from playwright.sync_api import expect, sync_playwright

    from tests import servers

    OUT.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as playwright:
        browser = servers.chromium_launch(playwright)

        def pages(user: str, shots: list[tuple[str, str, str]], *, whole: bool = True) -> None:
            """Each (path, a selector to wait for, file) as `user` sees it; `whole`: the whole
            page, else what the window shows (the top of a long page)."""
            context = browser.new_context(
                base_url=http, viewport={"width": 1280, "height": 860}, locale="en-GB"
            )
            page = context.new_page()
            page.goto("/accounts/login/")
            page.get_by_label("Username").fill(user)
            page.get_by_label("Password").fill(PASSWORD)
            page.get_by_role("button", name="Log in").click()
            expect(page.get_by_role("button", name="Log out")).to_be_visible()
            for path, ready, name in shots:
                sweeps_fresh()
                page.goto(path)
                expect(page.locator(ready).first).to_be_visible()
                status = page.locator("#live-status")
                if status.count() and status.get_attribute("data-state") != "off":
                    expect(status).to_have_text("Live")
                page.mouse.move(0, 0)
                page.screenshot(path=OUT / name, full_page=whole)
                print(f"wrote {OUT / name}")
            context.close()

        pages("minji", [("/", "#request-title", "deliveries.png")])
        pages(
            "jisoo",
            [
                ("/fleet/?floor=6F", "#live-status", "fleet.png"),
                ("/robots/R1/", "#live-status", "robot.png"),
            ],
        )
        pages("jisoo", [("/reports/", "canvas", "reports.png")], whole=False)
        editor = ("/maps/eulji/edit", "#editor-waypoints > *", "map-editor.png")
        pages("hana", [editor], whole=False)
        # R1 reaches the laboratory with the blood samples and waits to be unloaded.
        robots["R1"].beat(
            status="waiting_unload",
            floor="2F",
            waypoint="2F-LAB-DROP",
            x=4,
            y=34,
            events=[{"type": "arrived", "task": robots["blood"], "stop": 1}],
        )
        pages("minji", [("/stations/2F-LAB-DROP/", ".announce-here", "station.png")])
        browser.close()


if __name__ == "__main__":
    main()
