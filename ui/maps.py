"""Pages of the site's map for administrators: the floor editor (it edits the draft through
the JSON API of maps/views.py), the history of published versions with their rollback, and
each version's export as a site file."""

from django.conf import settings
from django.contrib import messages
from django.http import HttpResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.views.decorators.http import require_POST

from core.access import admin_required
from maps.choices import Rollout
from maps.documents import document_yaml
from maps.models import MapVersion
from maps.services import MapBlocked, MapInvalid, draft_open, version_restore
from robots.models import Site
from robots.selectors import sites_all
from ui.drawing import MAP_MARGIN


@admin_required
def map_editor(request, site: str):
    site = get_object_or_404(Site, code=site)
    context = {
        "edited_site": site,
        "sites": sites_all(),
        "draft": draft_open(site=site),
        "margin": MAP_MARGIN,
        "rollouts": Rollout.choices,
        # The default name is in the site's default language; the others are given per language.
        "name_languages": [
            (code, name) for code, name in settings.LANGUAGES if code != settings.LANGUAGE_CODE
        ],
    }
    return render(request, "maps/editor.html", context)


@admin_required
def map_history(request, site: str):
    site = get_object_or_404(Site, code=site)
    draft_open(site=site)  # records the live map as a version if load_site put it there
    versions = MapVersion.objects.filter(site=site).select_related("author")
    context = {"edited_site": site, "versions": versions, "sites": sites_all()}
    return render(request, "maps/history.html", context)


@admin_required
def map_export(request, site: str, number: int):
    version = get_object_or_404(MapVersion, site__code=site, number=number)
    response = HttpResponse(document_yaml(version.document), content_type="application/yaml")
    name = f"{version.site.code}-map-v{version.number}.yaml"
    response["Content-Disposition"] = f'attachment; filename="{name}"'
    return response


@require_POST
@admin_required
def map_restore_post(request, site: str, number: int):
    site = get_object_or_404(Site, code=site)
    get_object_or_404(MapVersion, site=site, number=number)
    try:
        version = version_restore(site=site, number=number, user=request.user)
    except MapBlocked as blocked:
        what = [*blocked.impact.blockers, *(f"{c.robot}'s route" for c in blocked.impact.cut)]
        messages.error(request, f"Version {number} was not restored: {'; '.join(what)}.")
    except MapInvalid as invalid:
        messages.error(request, f"Version {number} was not restored: {'; '.join(invalid.problems)}")
    else:
        messages.success(request, f"Version {number} restored as version {version.number}.")
    return redirect("map-history", site=site.code)
