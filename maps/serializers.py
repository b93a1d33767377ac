"""The map editor's API: what it sends and what it is answered."""

from rest_framework import serializers

from core.fields import StrictCharField, StrictIntegerField
from maps.choices import Rollout

MAX_UPLOAD = 2_000_000  # characters of a site file (the Eulji demo site is about 25,000)


class RevisionSerializer(serializers.Serializer):
    revision = StrictIntegerField(min_value=1, help_text="the draft revision the editor last read")


class DraftSaveSerializer(RevisionSerializer):
    document = serializers.JSONField(help_text="the whole site file; may be invalid")
    rollout = serializers.ChoiceField(choices=Rollout.choices, required=False)

    def validate_document(self, value):
        if not isinstance(value, dict):
            raise serializers.ValidationError("must be a mapping (site, floors, ...)")
        return value


class DraftUploadSerializer(RevisionSerializer):
    name = StrictCharField(max_length=200, help_text="the file's name: .json is JSON, else YAML")
    text = StrictCharField(max_length=MAX_UPLOAD, trim_whitespace=False)


class PublishSerializer(RevisionSerializer):
    note = StrictCharField(max_length=500, required=False, allow_blank=True, default="")


class RestoreSerializer(serializers.Serializer):
    note = StrictCharField(max_length=500, required=False, allow_blank=True, default="")


class RolloutSerializer(serializers.Serializer):
    rollout = serializers.ChoiceField(choices=Rollout.choices)


def draft_wire(draft) -> dict:
    return {
        "site": draft.site_id and draft.site.code,
        "revision": draft.revision,
        "base_version": draft.base_version,
        "rollout": draft.rollout,
        "updated_at": draft.updated_at,
        "updated_by": draft.updated_by.get_username() if draft.updated_by else None,
        "document": draft.document,
    }


def check_wire(check) -> dict:
    return {
        "revision": check.draft.revision,
        "rollout": check.draft.rollout,
        "live_version": check.draft.site.map_version,
        "problems": check.problems,
        "changes": [change.wire() for change in check.diff.changes],
        **check.impact.wire(),
    }


def version_wire(version) -> dict:
    return {
        "number": version.number,
        "author": version.author.get_username() if version.author else None,
        "published_at": version.published_at,
        "note": version.note,
        "restored_from": version.restored_from,
        "replanned": version.replanned,
    }


def problems_by_place(problems: list[str], *, field: str = "document") -> dict[str, list[str]]:
    """Site-file problems ("floors[0].edges[2]: unknown waypoint 'X'") as field errors of the
    document ("document.floors[0].edges[2]": ["unknown waypoint 'X'"]); those of an uploaded
    file's text all under its field."""
    if field != "document":
        return {field: list(problems)}
    detail: dict[str, list[str]] = {}
    for problem in problems:
        place, sep, what = problem.partition(": ")
        if not sep or " " in place:
            place, what = "", problem
        key = f"document.{place}" if place else "document"
        detail.setdefault(key, []).append(what)
    return detail


# --- What is answered (for the API's schema; the views answer the *_wire dicts) ---------------


class DraftSerializer(serializers.Serializer):
    site = serializers.CharField()
    revision = serializers.IntegerField()
    base_version = serializers.IntegerField(help_text="the map version the draft started from")
    rollout = serializers.ChoiceField(choices=Rollout.choices)
    updated_at = serializers.DateTimeField()
    updated_by = serializers.CharField(allow_null=True)
    document = serializers.JSONField(help_text="the whole site file")


class ChangeSerializer(serializers.Serializer):
    what = serializers.CharField(help_text="floor, waypoint, edge, station or resource")
    how = serializers.CharField(help_text="added, removed, moved, renamed or changed")
    code = serializers.CharField()
    detail = serializers.CharField()


class RouteCutSerializer(serializers.Serializer):
    robot = serializers.CharField()
    crosses = serializers.ListField(child=serializers.CharField())


class CheckSerializer(serializers.Serializer):
    revision = serializers.IntegerField()
    rollout = serializers.ChoiceField(choices=Rollout.choices)
    live_version = serializers.IntegerField()
    problems = serializers.ListField(child=serializers.CharField(), help_text="by place")
    changes = ChangeSerializer(many=True)
    routes = RouteCutSerializer(many=True, help_text="robots whose current route is cut")
    blockers = serializers.ListField(
        child=serializers.CharField(), help_text="what forbids publishing whatever the site chose"
    )


class VersionSerializer(serializers.Serializer):
    number = serializers.IntegerField()
    author = serializers.CharField(allow_null=True)
    published_at = serializers.DateTimeField()
    note = serializers.CharField()
    restored_from = serializers.IntegerField(allow_null=True)
    replanned = serializers.ListField(child=serializers.CharField())


class VersionDocumentSerializer(VersionSerializer):
    document = serializers.JSONField(help_text="the site file as published")
