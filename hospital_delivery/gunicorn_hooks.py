"""gunicorn's server hooks (Procfile: `--config python:hospital_delivery.gunicorn_hooks`)."""


def on_starting(server):
    """Before the workers are forked: the requests and processor time each counts are the
    pool's (core/busy.py), so that each reads what the whole pool serves."""
    from core.busy import busy

    busy.pool_share()


def post_worker_init(worker):
    """Each worker reads the queue on its listening sockets at every request (core/busy.py):
    how the heartbeat cadence tells a saturated pool from a busy one (robots/cadence.py)."""
    from core.busy import busy

    busy.listeners_watch([listener.sock for listener in worker.sockets], pool=worker.cfg.workers)
