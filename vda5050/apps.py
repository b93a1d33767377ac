from django.apps import AppConfig


class Vda5050Config(AppConfig):
    name = "vda5050"
    verbose_name = "VDA 5050 bridge"
