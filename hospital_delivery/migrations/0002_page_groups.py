"""The two groups the pages know (core.access): nurse and operator."""

from django.db import migrations

GROUPS = ["nurse", "operator"]


def groups_create(apps, schema_editor):
    Group = apps.get_model("auth", "Group")
    for name in GROUPS:
        Group.objects.get_or_create(name=name)


class Migration(migrations.Migration):

    dependencies = [
        ("auth", "0012_alter_user_first_name_max_length"),
        ("hospital_delivery", "0001_initial"),
    ]

    operations = [
        # Reversing keeps the groups: users may have been put in them since.
        migrations.RunPython(groups_create, migrations.RunPython.noop),
    ]
