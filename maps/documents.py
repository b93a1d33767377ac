"""Site files as documents: the live map written out as one (the format `load_site` reads),
and a document as YAML text.

A document exported here and loaded again gives the same map: same floors, waypoints (kind,
name, position), edges (length, direction, guard), resources and robots.
"""

import math

import yaml

from robots.choices import ResourceKind, RobotProtocol
from robots.models import Edge, Floor, Resource, ResourceWaypoint, Robot, Site, Waypoint
from robots.sitefile import SITE_SETTINGS

LENGTH_TOLERANCE = 1e-6  # metres: an edge this close to the straight line is written [A, B]


def site_document(site: Site) -> dict:
    """The site's live map and settings as a site file (seven queries, however big)."""
    floors = list(Floor.objects.filter(site=site).order_by("-level"))
    waypoints = list(Waypoint.objects.filter(site=site).order_by("floor__level", "code"))
    by_id = {wp.pk: wp for wp in waypoints}
    resources = list(Resource.objects.filter(site=site).order_by("code"))
    document = {"site": site.code}
    document.update({name: getattr(site, name) for name in SITE_SETTINGS})
    edges = list(Edge.objects.filter(site=site).order_by("id"))
    document["floors"] = [_floor(floor, waypoints, edges, by_id) for floor in floors]
    floor_codes = {floor.pk: floor.code for floor in floors}
    document["resources"] = _resources(resources, by_id, floor_codes)
    document["robots"] = [_robot(robot) for robot in site.robots.select_related("dock")]
    return document


def _floor(
    floor: Floor, waypoints: list[Waypoint], edges: list[Edge], by_id: dict[int, Waypoint]
) -> dict:
    here = [wp for wp in waypoints if wp.floor_id == floor.pk]
    edges = [edge for edge in edges if by_id[edge.source_id].floor_id == floor.pk]
    entry = {"code": floor.code, "level": floor.level}
    if floor.name:
        entry["name"] = floor.name
    if floor.names:
        entry["names"] = floor.names
    entry["waypoints"] = [_waypoint(wp) for wp in here]
    entry["edges"] = [_edge(edge, by_id) for edge in edges]
    return entry


def _waypoint(wp: Waypoint) -> dict:
    entry = {"code": wp.code, "x": wp.x, "y": wp.y, "kind": wp.kind}
    if wp.name:
        entry["name"] = wp.name
    if wp.names:
        entry["names"] = wp.names
    return entry


def _edge(edge: Edge, by_id: dict[int, Waypoint]) -> list | dict:
    """[A, B] when two-way and as long as the straight line, else the long form."""
    a, b = by_id[edge.source_id], by_id[edge.target_id]
    straight = math.dist((a.x, a.y), (b.x, b.y))
    if not edge.oneway and abs(edge.length - straight) <= LENGTH_TOLERANCE:
        return [a.code, b.code]
    entry = {"from": a.code, "to": b.code, "length": edge.length}
    if edge.oneway:
        entry["oneway"] = True
    return entry


def _resources(
    resources: list[Resource], by_id: dict[int, Waypoint], floors: dict[int, str]
) -> list[dict]:
    stops: dict[int, list[Waypoint]] = {}
    for row in ResourceWaypoint.objects.filter(resource__in=resources):
        stops.setdefault(row.resource_id, []).append(by_id[row.waypoint_id])
    guards: dict[int, list[list[str]]] = {}
    for edge in Edge.objects.filter(guarded_by__in=resources).order_by("id"):
        pair = [by_id[edge.source_id].code, by_id[edge.target_id].code]
        guards.setdefault(edge.guarded_by_id, []).append(pair)
    return [_resource(r, stops.get(r.pk, []), guards.get(r.pk, []), floors) for r in resources]


def _resource(
    resource: Resource, stops: list[Waypoint], guards: list[list[str]], floors: dict[int, str]
) -> dict:
    entry = {"code": resource.code, "kind": resource.kind, "capacity": resource.capacity}
    if resource.name:
        entry["name"] = resource.name
    if resource.names:
        entry["names"] = resource.names
    stops = sorted(stops, key=lambda wp: wp.code)
    if resource.kind == ResourceKind.ELEVATOR:
        entry["stops"] = {floors[wp.floor_id]: wp.code for wp in stops}
        entry["seconds_per_floor"] = resource.seconds_per_floor
        entry["overhead_seconds"] = resource.overhead_seconds
    else:
        entry["waiting"] = [wp.code for wp in stops]
        entry["guards"] = guards
    return entry


def _robot(robot: Robot) -> dict:
    entry = {"code": robot.code, "dock": robot.dock.code}
    if robot.compartments:
        entry["compartments"] = robot.compartments
    else:
        entry["capacity"] = robot.capacity
    if robot.name:
        entry["name"] = robot.name
    if robot.protocol == RobotProtocol.VDA5050:
        entry.update(
            protocol=robot.protocol,
            manufacturer=robot.manufacturer,
            serial_number=robot.serial_number,
        )
        if robot.vda5050:
            entry["vda5050"] = robot.vda5050
    return entry


def document_yaml(document: dict) -> str:
    """The document as a YAML site file, keys in the file's order."""
    header = f"# Site file of '{document.get('site', '')}': load with manage.py load_site FILE\n"
    body = yaml.safe_dump(document, sort_keys=False, allow_unicode=True, default_flow_style=None)
    return header + body
