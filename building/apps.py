from django.apps import AppConfig


class BuildingConfig(AppConfig):
    default_auto_field = "django.db.models.BigAutoField"
    name = "building"
    verbose_name = "building devices (lifts and doors)"
