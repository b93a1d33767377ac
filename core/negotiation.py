"""Content negotiation for endpoints that only ever answer JSON (the robots' heartbeat)."""

from rest_framework.negotiation import BaseContentNegotiation


class JsonOnly(BaseContentNegotiation):
    """The view's first parser and renderer, whatever the request's Accept header says.

    DRF's default negotiation parses the Accept header and matches it against every renderer
    on each request: 3 % of a heartbeat's CPU for an answer that is JSON anyway (a robot is
    not a browser wanting the browsable API). The pattern is DRF's own documentation's
    ("Custom content negotiation")."""

    def select_parser(self, request, parsers):
        return parsers[0] if parsers else None

    def select_renderer(self, request, renderers, format_suffix=None):
        return renderers[0], renderers[0].media_type
