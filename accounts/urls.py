from django.urls import path

from accounts import views

# The names mozilla-django-oidc reverses (the callback's is the redirect_uri sent to the provider).
urlpatterns = [
    path("oidc/authenticate/", views.SignInView.as_view(), name="oidc_authentication_init"),
    path("language/", views.language_choose, name="language"),
    path("oidc/callback/", views.CallbackView.as_view(), name="oidc_authentication_callback"),
]
