from django.apps import AppConfig


class UiConfig(AppConfig):
    name = "ui"
    verbose_name = "Pages for nurses and operators, live over websockets"
