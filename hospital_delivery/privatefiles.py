"""The SQLite database holds live session keys and token hashes: readable by its owner only.

Django creates db.sqlite3 with the process's umask (usually 0644); on every new connection
its mode is narrowed to 0600 (a receiver of Django's connection_created, connected in
hospital_delivery/extensions.py). SQLite creates the -wal and -shm files with the database file's
mode, so they follow.
"""

import os
import stat


def sqlite_private(sender, connection, **kwargs) -> None:
    if connection.vendor != "sqlite":
        return
    path = str(connection.settings_dict["NAME"])
    for name in (path, f"{path}-wal", f"{path}-shm"):
        try:
            mode = stat.S_IMODE(os.stat(name).st_mode)
        except (FileNotFoundError, ValueError):  # ":memory:", or not created yet
            continue
        if mode & 0o077:
            os.chmod(name, 0o600)
