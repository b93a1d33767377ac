"""DRF serializers made once per thread for the hot path."""

import threading

from django.utils.functional import cached_property
from rest_framework import serializers


class FieldsKeptPerThread:
    """A serializer whose fields are made once per thread and class, not once per instance.

    DRF deep-copies every declared field of a serializer for each instance, nested serializers
    and their fields included: for the heartbeat some twenty fields made again on every request,
    a large share of its CPU (bench/heartbeat_cpu.py). A field keeps nothing of a
    validation, only the serializer it is bound to, through which it reaches the `context`; so
    each thread keeps the first instance's fields, and every later instance of the class takes
    them over as their parent. One thread validates one body at a time, so no two instances
    share them at once.
    """

    _kept = threading.local()

    @cached_property
    def fields(self):
        kept = self._kept.__dict__
        fields = kept.get(type(self))
        if fields is None:
            fields = kept[type(self)] = serializers.Serializer.fields.func(self)
        for field in fields.values():
            field.parent = self
        return fields
