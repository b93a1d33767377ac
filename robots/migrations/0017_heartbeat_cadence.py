from django.db import migrations, models


def cadence_row_create(apps, schema_editor):
    """The one row every web process reads and writes (robots/cadence.py)."""
    apps.get_model("robots", "HeartbeatCadence").objects.create(pk=1)


class Migration(migrations.Migration):
    dependencies = [
        ("robots", "0016_robot_heartbeat_updates_in_place"),
    ]

    operations = [
        migrations.CreateModel(
            name="HeartbeatCadence",
            fields=[
                (
                    "id",
                    models.BigAutoField(
                        auto_created=True, primary_key=True, serialize=False, verbose_name="ID"
                    ),
                ),
                ("interval", models.FloatField(default=0.0)),
                ("cpu_share", models.FloatField(default=0.0)),
                ("changed_at", models.DateTimeField(null=True)),
                ("backlog_seconds", models.FloatField(default=0.0)),
                ("backlog_at", models.DateTimeField(null=True)),
            ],
            options={
                "db_table": "robots_heartbeat_cadence",
            },
        ),
        migrations.RunPython(cadence_row_create, migrations.RunPython.noop),
    ]
