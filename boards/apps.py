from django.apps import AppConfig


class BoardsConfig(AppConfig):
    name = "boards"
    verbose_name = "Message boards and robot heartbeats"

    def ready(self):
        from boards import receivers

        receivers.connect()
