"""The group of hospital systems that order over FHIR (core.access.INTEGRATION)."""

from django.db import migrations


def group_create(apps, schema_editor):
    Group = apps.get_model("auth", "Group")
    Group.objects.get_or_create(name="integration")


class Migration(migrations.Migration):

    dependencies = [
        ("hospital_delivery", "0003_sign_in_throttle"),
    ]

    operations = [
        # Reversing keeps the group: users may have been put in it since.
        migrations.RunPython(group_create, migrations.RunPython.noop),
    ]
