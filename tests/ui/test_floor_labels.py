"""The floor map's labels never run into each other or cover a station, dock or waiting area:
each goes above its point, else below, else is left to the point's tooltip (ui/drawing.py)."""

from pathlib import Path

import yaml
from django.conf import settings

from robots.models import Site
from robots.sitefile import site_load
from ui.drawing import _overlap, _symbol_box, _text_box, floor_drawing, floors_of

EULJI = Path(settings.BASE_DIR, "sites", "eulji.yaml")


def written_labels(drawing) -> list[tuple]:
    boxes = []
    for wp in drawing.waypoints:
        if wp.label_y is not None:
            boxes.append(_text_box(wp, wp.label, wp.label_y))
        if wp.resources_y is not None:
            boxes.append(_text_box(wp, wp.resources_label, wp.resources_y))
    return boxes


def test_it_writes_the_demo_site_s_labels_apart(db):
    site_load(data=yaml.safe_load(EULJI.read_text(encoding="utf-8")))
    site = Site.objects.get(code="eulji")
    written = named = 0
    for floor, _name in floors_of(site=site):
        drawing = floor_drawing(site=site, floor=floor)
        boxes = written_labels(drawing)
        symbols = [_symbol_box(wp) for wp in drawing.waypoints if wp.kind != "plain"]
        clashes = [(a, b) for n, a in enumerate(boxes) for b in boxes[n + 1 :] if _overlap(a, b)]
        covered = [(a, s) for a in boxes for s in symbols if _overlap(a, s)]
        assert (clashes, covered) == ([], []), floor
        written += len(boxes)
        named += sum(1 for wp in drawing.waypoints if wp.kind in ("station", "dock"))
        named += sum(1 for wp in drawing.waypoints if wp.resources)
    assert written >= 0.9 * named  # only a crowded few are left to their tooltips


def test_it_writes_each_resource_once_per_floor(site):
    drawing = floor_drawing(site=site, floor="2F")  # DOOR-2F has a waiting area on each side

    labels = [wp.resources_label for wp in drawing.waypoints if wp.resources_y is not None]
    written = [code for label in labels for code in label.split(", ")]
    assert sorted(written) == sorted(set(written))
    assert "DOOR-2F" in written
