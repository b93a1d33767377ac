from django.apps import AppConfig


class HospitalDeliveryConfig(AppConfig):
    name = "hospital_delivery"
    verbose_name = "Accounts and API tokens"

    def ready(self):
        from hospital_delivery import (
            privatefiles,  # noqa: F401  (SQLite file mode 600)
            schema,  # noqa: F401  (registers OpenAPI extensions)
        )
