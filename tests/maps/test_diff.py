"""The map editor's Check compares a draft with the live map as a person reads them: numbers
as numbers however written, a resource's waiting points and guarded edges in any order."""

import copy

from maps.diff import map_diff
from maps.documents import site_document


def as_the_editor_writes_it(document: dict) -> dict:
    """Every coordinate and length as a float (40.0), every list of a resource reversed."""
    draft = copy.deepcopy(document)
    for floor in draft["floors"]:
        for wp in floor["waypoints"]:
            wp["x"], wp["y"] = float(wp["x"]), float(wp["y"])
        for edge in floor["edges"]:
            if isinstance(edge, dict) and isinstance(edge.get("length"), int | float):
                edge["length"] = float(edge["length"])
    for resource in draft["resources"]:
        for key, value in resource.items():
            if isinstance(value, list):
                resource[key] = value[::-1]
    return draft


def test_it_finds_no_change_in_the_live_map_written_otherwise(site):
    live = site_document(site)
    draft = as_the_editor_writes_it(live)
    assert any(r.get("waiting") for r in draft["resources"])  # the site has lists to reorder

    assert map_diff(live, draft).changes == []


def test_it_still_finds_the_one_real_change(site):
    live = site_document(site)
    draft = as_the_editor_writes_it(live)
    hall = next(wp for f in draft["floors"] for wp in f["waypoints"] if wp["code"] == "1F-HALL")
    hall["x"] += 0.5
    corridor = next(r for r in draft["resources"] if r.get("waiting"))
    corridor["waiting"] = corridor["waiting"][:1]

    changes = [(c.what, c.how, c.code) for c in map_diff(live, draft).changes]

    assert changes == [("waypoint", "moved", "1F-HALL"), ("resource", "changed", corridor["code"])]
    moved = map_diff(live, draft).changes[0]
    assert moved.detail.endswith(f"→ ({hall['x']}, {hall['y']}) on 1F")
