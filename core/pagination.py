"""API pagination with bounds: a page size and an offset the database can take."""

from rest_framework import exceptions
from rest_framework.pagination import LimitOffsetPagination

MAX_OFFSET = 2**31 - 1


class BoundedLimitOffsetPagination(LimitOffsetPagination):
    max_limit = 1000  # a larger ?limit= gets this many

    def get_offset(self, request):
        offset = super().get_offset(request)
        if offset > MAX_OFFSET:
            raise exceptions.ValidationError({self.offset_query_param: [f"over {MAX_OFFSET}"]})
        return offset
