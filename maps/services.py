"""Writes of the map editor: the draft, publishing it as a new map version, rolling back.

Publishing applies the draft's site file through the loader `load_site` uses (one transaction),
after checking the running fleet (maps/impact.py). Lock order, as the scheduler's
(scheduling/services/__init__.py): the site's allocation lock first, so no allocation plans on
the old map meanwhile; then the site's robots in id order (nothing else holds two, nor waits for
one while holding the allocation lock); then the site row, in the loader.
"""

from dataclasses import dataclass, field

from django.db import IntegrityError, transaction
from django.utils import timezone

from audit.choices import Kind
from audit.services import entry_record
from maps.choices import Rollout
from maps.diff import MapDiff, map_diff
from maps.documents import site_document
from maps.impact import Impact, rollout_impact
from maps.models import MapDraft, MapVersion
from robots.choices import WaypointKind
from robots.mapcache import site_map_forget
from robots.models import Robot, Site
from robots.services import robot_lock
from robots.sitefile import SiteFileInvalid, site_file_parse, site_file_validate, site_load
from scheduling.services.allocation import allocation_lock_take
from scheduling.services.plans import robot_replan

BASELINE_NOTE = "the map as loaded from a site file (manage.py load_site)"


class MapInvalid(Exception):
    """The document is not a valid site file for this site: every problem, by place."""

    def __init__(self, problems: list[str], *, field: str = "document"):
        super().__init__(problems)
        self.problems = problems
        self.field = field  # the request's field they are about


class MapBlocked(Exception):
    """Publishing would strand a robot or a delivery; nothing was written."""

    def __init__(self, impact: Impact):
        super().__init__(impact.blockers, impact.cut)
        self.impact = impact


class StaleRevision(Exception):
    """The draft changed since the editor read it (another administrator saved)."""

    def __init__(self, current: int):
        super().__init__(current)
        self.current = current


@dataclass
class DraftCheck:
    """The draft as it would be published now: its problems, its changes, their impact."""

    draft: MapDraft
    problems: list[str]
    diff: MapDiff
    impact: Impact = field(default_factory=Impact)


# --- The draft ---------------------------------------------------------------------------------


def draft_open(*, site: Site) -> MapDraft:
    """The site's draft; the first time, a copy of the live map (recorded as its version)."""
    draft = MapDraft.objects.filter(site=site).first()
    if draft is not None:
        return draft
    with transaction.atomic():
        document = site_document(site)
        _baseline_record(site, document)
        draft, _created = MapDraft.objects.get_or_create(
            site=site, defaults={"document": document, "base_version": site.map_version}
        )
    return draft


@transaction.atomic
def draft_save(*, site: Site, document: dict, revision: int, user, rollout: str | None = None):
    """Replace the draft's document (invalid ones too: validation lists their problems)."""
    _document_of_site(site, document)
    draft = _draft_lock(site, revision)
    draft.document = document
    if rollout is not None:
        draft.rollout = rollout
    return _draft_touch(draft, user)


def draft_upload(*, site: Site, text: str, name: str, revision: int, user) -> MapDraft:
    """A site file's text (YAML or JSON) as the draft."""
    if "\x00" in text:
        raise MapInvalid([f"{name}: holds a NUL character"], field="text")
    try:
        document = site_file_parse(text, name=name)
    except SiteFileInvalid as exc:
        raise MapInvalid(exc.problems, field="text") from None
    return draft_save(site=site, document=document, revision=revision, user=user)


@transaction.atomic
def draft_rollout_set(*, site: Site, rollout: str, user) -> MapDraft:
    draft_open(site=site)
    draft = MapDraft.objects.select_for_update().get(site=site)
    draft.rollout = rollout
    return _draft_touch(draft, user)


@transaction.atomic
def draft_reset(*, site: Site, revision: int, user) -> MapDraft:
    """Throw the draft's edits away: the live map again."""
    draft = _draft_lock(site, revision)
    draft.document = site_document(site)
    draft.base_version = site.map_version
    return _draft_touch(draft, user)


def draft_check(*, site: Site) -> DraftCheck:
    """Validate the draft and compare it with the live map (read-only)."""
    draft = draft_open(site=site)
    problems = _problems(site, draft.document)
    diff = map_diff(site_document(site), draft.document)
    impact = rollout_impact(site=site, diff=diff, now=timezone.now())
    return DraftCheck(draft=draft, problems=problems, diff=diff, impact=impact)


def _draft_lock(site: Site, revision: int) -> MapDraft:
    draft_open(site=site)
    draft = MapDraft.objects.select_for_update().get(site=site)
    if draft.revision != revision:
        raise StaleRevision(draft.revision)
    return draft


def _draft_touch(draft: MapDraft, user) -> MapDraft:
    draft.revision += 1
    draft.updated_at = timezone.now()
    draft.updated_by = user if user is not None and user.is_authenticated else None
    draft.save()
    return draft


def _document_of_site(site: Site, document) -> None:
    if not isinstance(document, dict):
        raise MapInvalid(["the document must be a mapping (site, floors, ...)"])
    if document.get("site") != site.code:
        raise MapInvalid([f"site: must be '{site.code}', the site being edited"])


def _problems(site: Site, document: dict) -> list[str]:
    try:
        _document_of_site(site, document)
    except MapInvalid as exc:
        return exc.problems
    return site_file_validate(document) + _unnamed_stations(document)


def _unnamed_stations(document: dict) -> list[str]:
    """A station published without a name would show to nurses as its code."""
    problems = []
    floors = document.get("floors")
    for f, floor in enumerate(floors if isinstance(floors, list) else []):
        waypoints = floor.get("waypoints") if isinstance(floor, dict) else None
        for w, wp in enumerate(waypoints if isinstance(waypoints, list) else []):
            if not isinstance(wp, dict) or wp.get("kind") != WaypointKind.STATION:
                continue
            name = wp.get("name")
            if not (isinstance(name, str) and name.strip()):
                problems.append(
                    f"floors[{f}].waypoints[{w}].name: station '{wp.get('code')}' needs a name:"
                    " nurses find it and see it by its name"
                )
    return problems


# --- Publishing ---------------------------------------------------------------------------------


def draft_publish(*, site: Site, revision: int, user, note: str = "") -> MapVersion:
    """Publish the draft (the revision the administrator looked at) as a new map version."""
    with transaction.atomic():
        draft = _draft_lock(site, revision)
        version = _publish(site, draft.document, user=user, note=note, rollout=draft.rollout)
        draft.document = version.document
        draft.base_version = version.number
        _draft_touch(draft, user)
    return version


def version_restore(*, site: Site, number: int, user, note: str = "") -> MapVersion:
    """Roll back: publish an older version's document again, as a new version."""
    old = MapVersion.objects.get(site=site, number=number)
    draft = draft_open(site=site)
    note = note or f"rollback to version {number}"
    with transaction.atomic():
        return _publish(
            site, old.document, user=user, note=note, rollout=draft.rollout, restored_from=number
        )


def _publish(
    site: Site, document: dict, *, user, note: str, rollout: str, restored_from: int | None = None
) -> MapVersion:
    problems = _problems(site, document)
    if problems:
        raise MapInvalid(problems)
    now = timezone.now()
    try:
        site = allocation_lock_take(site.pk)
        for robot_id in Robot.objects.filter(site=site).order_by("pk").values_list("pk", flat=True):
            robot_lock(robot_id)
        site = Site.objects.get(pk=site.pk)
        live, live_number = site_document(site), site.map_version
        impact = rollout_impact(site=site, diff=map_diff(live, document), now=now)
        if impact.blockers or (impact.cut and rollout == Rollout.REFUSE):
            raise MapBlocked(impact)
        _baseline_record(site, live)
        try:
            site = site_load(data=document)
        except SiteFileInvalid as exc:
            raise MapInvalid(exc.problems) from None
        replanned = _replan(impact, now)
        version = MapVersion.objects.create(
            site=site,
            number=site.map_version,
            document=document,
            author=user if user is not None and user.is_authenticated else None,
            published_at=now,
            note=note[:500],
            restored_from=restored_from,
            replanned=replanned,
        )
        _publish_audit(version, live_number=live_number)
        return version
    except BaseException:
        # This transaction may have cached the new map under a version number that now rolls
        # back and would be reused by the next publication.
        site_map_forget(site.pk)
        raise


def _publish_audit(version: MapVersion, *, live_number) -> None:
    """Who published which map version over which (a roll-back names the version restored)."""
    entry_record(
        kind=Kind.MAP_PUBLISHED,
        obj=version,
        actor=version.author,
        site_id=version.site_id,
        object_repr=f"{version.site.code} map version {version.number}",
        changes={"map_version": [live_number, version.number]},
        data={"note": version.note, "restored_from": version.restored_from},
    )


def _replan(impact: Impact, now) -> list[str]:
    """Post each robot whose route the new map cut a plan routed on the new map (robot rows
    locked above; robot_lock reads them again, with the site's new map_version)."""
    codes = [cut.robot for cut in impact.cut]
    for robot in Robot.objects.filter(code__in=codes).order_by("pk"):
        robot_replan(robot=robot_lock(robot.pk), now=now)
    return codes


def version_get(*, site: Site, number: int) -> MapVersion:
    """A published version (MapVersion.DoesNotExist if none). The live map is one from the
    start: loaded by `load_site`, it is kept as its version the first time it is asked for,
    so whoever follows the site's map version (the simulated fleet's traffic) finds it."""
    found = MapVersion.objects.select_related("author").filter(site=site, number=number).first()
    if found is not None:
        return found
    if number != site.map_version:
        raise MapVersion.DoesNotExist(f"no version {number} of {site.code}'s map")
    try:
        with transaction.atomic():
            _baseline_record(site, site_document(site))
    except IntegrityError:
        pass  # kept meanwhile by another request
    return MapVersion.objects.select_related("author").get(site=site, number=number)


def _baseline_record(site: Site, document: dict) -> None:
    """Keep the live map as a version if it was loaded by `load_site` rather than published."""
    if not MapVersion.objects.filter(site=site, number=site.map_version).exists():
        MapVersion.objects.create(
            site=site,
            number=site.map_version,
            document=document,
            published_at=site.loaded_at or timezone.now(),
            note=BASELINE_NOTE,
        )
