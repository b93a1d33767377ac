"""The periodic sweeps (Celery beat, every second) log only what they changed."""

import logging

logger = logging.getLogger("sweeps")


def sweep_report(name: str, changed: int | dict[str, int]) -> None:
    """Log a sweep's outcome if it changed anything: a count, or counts by what they count."""
    counts = changed if isinstance(changed, dict) else {"changed": changed}
    done = {what: count for what, count in counts.items() if count}
    if done:
        logger.info("%s: %s", name, ", ".join(f"{count} {what}" for what, count in done.items()))
