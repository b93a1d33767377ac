from django.apps import AppConfig


class HospitalDeliveryConfig(AppConfig):
    name = "hospital_delivery"
    verbose_name = "Accounts and API tokens"
