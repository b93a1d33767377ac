"""The group of auditors, who read the audit trail of their sites (core.access.AUDITOR)."""

from django.db import migrations


def group_create(apps, schema_editor):
    Group = apps.get_model("auth", "Group")
    Group.objects.get_or_create(name="auditor")


class Migration(migrations.Migration):

    dependencies = [
        ("audit", "0001_audit_entries_and_chain"),
        ("auth", "0012_alter_user_first_name_max_length"),
    ]

    operations = [
        # Reversing keeps the group: users may have been put in it since.
        migrations.RunPython(group_create, migrations.RunPython.noop),
    ]
