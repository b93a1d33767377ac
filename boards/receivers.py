"""The boards app's reactions to the rest of the project: connected in BoardsConfig.ready()."""

from django.contrib.auth.signals import user_logged_out

from boards.events import session_sockets_close


def on_user_logged_out(sender, request, user, **kwargs):
    session_key = getattr(request, "session", None) and request.session.session_key
    if session_key:
        session_sockets_close(session_key=session_key)


def connect() -> None:
    user_logged_out.connect(on_user_logged_out, dispatch_uid="boards-close-sockets-on-logout")
