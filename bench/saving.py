"""`--save`: a benchmark's printed tables kept in bench/results/, one file per benchmark and day.

    @saving.saves("allocation")
    def main(argv=None):
        parser = argparse.ArgumentParser(...)
        saving.add_argument(parser)
        ...

With `--save` on its command line, whatever the benchmark prints goes to the terminal as usual
and, once it has finished without an error, into bench/results/<UTC date>-<name>.md: the
command, when it ran, the machine it ran on and the printed text. A second run on the same day
is added to the same file. The documentation's figures (docs/performance.md) are taken from
these files, so each says where it came from.
"""

import functools
import io
import os
import platform
import sys
from collections.abc import Callable
from contextlib import redirect_stdout
from datetime import UTC, datetime
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
FLAG = "--save"


def add_argument(parser) -> None:
    parser.add_argument(
        FLAG,
        action="store_true",
        help="also write what is printed to bench/results/<UTC date>-<benchmark>.md",
    )


def saves(name: str) -> Callable:
    """Decorates a benchmark's main(argv=None): with --save, its output is kept (results_write)."""

    def decorate(main: Callable) -> Callable:
        @functools.wraps(main)
        def wrapper(argv: list[str] | None = None, *args, **kwargs):
            arguments = sys.argv[1:] if argv is None else list(argv)
            if FLAG not in arguments:
                return main(*([] if argv is None else [argv]), *args, **kwargs)
            started = datetime.now(UTC)
            printed = io.StringIO()
            with redirect_stdout(_Tee(sys.stdout, printed)):
                result = main(*([] if argv is None else [argv]), *args, **kwargs)
            if result in (None, 0):
                path = results_write(
                    name=name, arguments=arguments, started=started, printed=printed.getvalue()
                )
                print(f"saved {path}")
            return result

        return wrapper

    return decorate


def results_write(
    *,
    name: str,
    arguments: list[str],
    started: datetime,
    printed: str,
) -> Path:
    """Adds one run to bench/results/<date>-<name>.md (the file begun if it is the day's first)."""
    results = RESULTS
    path = results / f"{started:%Y-%m-%d}-{name}.md"
    command = " ".join(["python", f"bench/{name}.py", *arguments])
    run = [
        f"## {started:%H:%M} UTC: `{command}`",
        "",
        f"Machine: {machine_description()}.",
        "",
        "```text",
        printed.rstrip("\n"),
        "```",
        "",
    ]
    results.mkdir(parents=True, exist_ok=True)
    if path.exists():
        text = path.read_text().rstrip("\n") + "\n\n"
    else:
        title = f"# bench/{name}.py, {started:%Y-%m-%d}"
        text = f"{title}\n\nWritten by `--save` (bench/saving.py).\n\n"
    path.write_text(text + "\n".join(run))
    return path


def machine_description() -> str:
    """The processor, cores, memory, system and Python, and how loaded the machine was."""
    parts = [
        _cpu_model(),
        f"{os.cpu_count()} CPUs",
        _memory(),
        platform.platform(),
        f"Python {platform.python_version()}",
    ]
    if hasattr(os, "getloadavg"):
        parts.append("load average {:.2f} {:.2f} {:.2f} at the end".format(*os.getloadavg()))
    return ", ".join(part for part in parts if part)


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor()


def _memory() -> str:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return f"{int(line.split()[1]) / 1024 / 1024:.0f} GiB of memory"
    except OSError:
        pass
    return ""


class _Tee(io.TextIOBase):
    """Writes to the terminal and keeps a copy."""

    def __init__(self, terminal, copy: io.StringIO):
        self.terminal, self.copy = terminal, copy

    def write(self, text: str) -> int:
        self.copy.write(text)
        return self.terminal.write(text)

    def flush(self) -> None:
        self.terminal.flush()
