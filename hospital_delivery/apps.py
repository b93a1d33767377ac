from django.apps import AppConfig


class HospitalDeliveryConfig(AppConfig):
    name = "hospital_delivery"
    verbose_name = "Accounts and API tokens"

    def ready(self):
        from hospital_delivery import extensions, schema  # noqa: F401  (OpenAPI extensions)

        extensions.connect()
