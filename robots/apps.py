from django.apps import AppConfig


class RobotsConfig(AppConfig):
    name = "robots"
    verbose_name = "Sites and robots"

    def ready(self):
        from robots import receivers  # noqa: F401  (connects the resource controller)
