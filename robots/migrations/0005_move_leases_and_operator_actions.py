"""Leases moved to the resource controller's app (resources) and operators' actions to the
scheduler's (scheduling): their tables are renamed to the new apps' names, and the models leave
this app's state; resources.0001 and scheduling.0002 take them up, without touching the
database. Rows, ids, indexes and constraints stay as they are; content types (and so the
permissions given to groups) move with the models."""

from django.db import migrations

MOVED = {"lease": "resources", "operatoraction": "scheduling"}


def content_types_move(apps, schema_editor):
    ContentType = apps.get_model("contenttypes", "ContentType")
    for model, app_label in MOVED.items():
        if not ContentType.objects.filter(app_label=app_label, model=model).exists():
            ContentType.objects.filter(app_label="robots", model=model).update(app_label=app_label)


def content_types_back(apps, schema_editor):
    ContentType = apps.get_model("contenttypes", "ContentType")
    for model, app_label in MOVED.items():
        if not ContentType.objects.filter(app_label="robots", model=model).exists():
            ContentType.objects.filter(app_label=app_label, model=model).update(app_label="robots")


class Migration(migrations.Migration):

    dependencies = [
        ('contenttypes', '0002_remove_content_type_name'),
        ('robots', '0004_operator_actions'),
    ]

    operations = [
        migrations.AlterModelTable(name='lease', table='resources_lease'),
        migrations.AlterModelTable(name='operatoraction', table='scheduling_operatoraction'),
        migrations.RunPython(content_types_move, content_types_back),
        migrations.SeparateDatabaseAndState(
            state_operations=[
                migrations.RemoveField(model_name='operatoraction', name='by'),
                migrations.RemoveField(model_name='operatoraction', name='message'),
                migrations.RemoveField(model_name='operatoraction', name='robot'),
                migrations.DeleteModel(name='Lease'),
                migrations.DeleteModel(name='OperatorAction'),
            ],
        ),
    ]
