"""`--save` (bench/saving.py): a benchmark's printed output kept in bench/results/, with the
command and the machine, one file per benchmark and day; nothing kept without it, or when the
benchmark fails."""

import argparse
from pathlib import Path

import pytest
import time_machine

from bench import saving


@saving.saves("toy")
def toy(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rows", type=int, default=2)
    parser.add_argument("--fail", action="store_true")
    saving.add_argument(parser)
    options = parser.parse_args(argv)
    print("robots  achieved/s")
    for row in range(options.rows):
        print(f"{100 * (row + 1):>6}  {99 * (row + 1):>10}")
    if options.fail:
        raise RuntimeError("the server did not start")
    return 0


@pytest.fixture
def results(tmp_path, monkeypatch):
    monkeypatch.setattr(saving, "RESULTS", tmp_path)
    return tmp_path


def test_it_keeps_the_printed_table_with_its_command_and_machine(results, capsys):
    with time_machine.travel("2031-05-06 07:08:00+00:00", tick=False):
        assert toy(["--rows", "2", "--save"]) == 0

    printed = capsys.readouterr().out
    assert "   200         198" in printed  # the terminal still gets it
    saved = (results / "2031-05-06-toy.md").read_text()
    assert saved.startswith("# bench/toy.py, 2031-05-06\n")
    assert "## 07:08 UTC: `python bench/toy.py --rows 2 --save`" in saved
    assert "Machine: " in saved
    assert " CPUs, " in saved
    assert "Python 3." in saved
    assert "```text\nrobots  achieved/s\n   100          99\n   200         198\n```" in saved


def test_a_second_run_of_the_day_joins_the_same_file(results):
    with time_machine.travel("2031-05-06 07:08:00+00:00", tick=False):
        toy(["--save"])
    with time_machine.travel("2031-05-06 09:30:00+00:00", tick=False):
        toy(["--rows", "1", "--save"])

    assert [path.name for path in results.iterdir()] == ["2031-05-06-toy.md"]
    saved = (results / "2031-05-06-toy.md").read_text()
    assert saved.count("# bench/toy.py") == 1
    assert saved.index("## 07:08 UTC") < saved.index("## 09:30 UTC: `python bench/toy.py --rows 1")


def test_nothing_is_kept_without_save_or_when_the_benchmark_fails(results):
    assert toy(["--rows", "1"]) == 0
    with pytest.raises(RuntimeError):
        toy(["--fail", "--save"])

    assert list(results.iterdir()) == []


def test_every_benchmark_offers_save():
    bench = Path(saving.__file__).parent
    scripts = [
        path
        for path in sorted(bench.glob("*.py"))
        if 'if __name__ == "__main__":' in path.read_text()
        and path.name not in ("stack.py", "saving.py")
    ]
    assert {"allocation", "heartbeat", "latency"} <= {script.stem for script in scripts}
    for script in scripts:
        text = script.read_text()
        assert f'@saving.saves("{script.stem}")' in text, script.name
        assert "saving.add_argument(parser)" in text, script.name
