from rest_framework import serializers

from robots.models import Robot


class RobotStateSerializer(serializers.Serializer):
    """The last state the robot reported (protocol v1 state object)."""

    status = serializers.CharField()
    floor = serializers.CharField(source="floor.code", allow_null=True)
    waypoint = serializers.CharField(source="waypoint.code", allow_null=True)
    x = serializers.FloatField(allow_null=True)
    y = serializers.FloatField(allow_null=True)
    heading = serializers.FloatField(allow_null=True)
    battery = serializers.FloatField(allow_null=True)
    load = serializers.IntegerField()
    plan_version = serializers.IntegerField()
    errors = serializers.ListField(child=serializers.CharField())
    reported_at = serializers.DateTimeField(allow_null=True)


class RobotSerializer(serializers.ModelSerializer):
    site = serializers.CharField(source="site.code")
    dock = serializers.CharField(source="dock.code")
    state = RobotStateSerializer(source="*")

    class Meta:
        model = Robot
        fields = [
            "code",
            "name",
            "site",
            "dock",
            "capacity",
            "protocol",
            "presence",
            "last_seen_at",
            "unreachable_at",
            "offline_at",
            "paused_by_operator",
            "maintenance_since",
            "maintenance_until",
            "maintenance_reason",
            "state",
        ]
        read_only_fields = fields
