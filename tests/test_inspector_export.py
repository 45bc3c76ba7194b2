"""The inspector's recordings and parameter files are written whole or not at all."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from types import SimpleNamespace

import pytest

from demo_data_gen import generate
from inspector.recording import write_recording
from radcons.params import Params
from radcons.pipeline import Pipeline


@pytest.fixture(scope="module")
def run():
    return Pipeline(Params.from_preset("paper")).run(generate(size=96, seed=0, scenario="mixed"), until="objects")


def _rrd_readable(path) -> bool:
    from rerun.chunk import RrdReader

    return bool(RrdReader(str(path)).store().schema().entity_paths())


def test_a_failed_recording_leaves_nothing(tmp_path, run, monkeypatch):
    import radcons.record

    folder = tmp_path / "rec"
    kept = write_recording(folder, "pair", [(0, run)])
    calls = []

    def failing(*args, **kwargs):
        calls.append(1)
        raise KeyboardInterrupt  # as Ctrl+C in the middle of the writing

    monkeypatch.setattr(radcons.record, "log_run", failing)
    with pytest.raises(KeyboardInterrupt):
        write_recording(folder, "pair", [(0, run), (1, run)])
    assert calls
    assert sorted(path.name for path in folder.iterdir()) == [kept.name]
    assert _rrd_readable(kept)


def test_a_recording_killed_midway_leaves_no_rrd_and_the_next_one_clears_it(tmp_path, run):
    """kill -9 while a recording is written: no ``.rrd`` appears; the next recording into
    the folder removes the partial file and is whole."""
    folder = tmp_path / "rec"
    script = textwrap.dedent(
        f"""
        import time
        import radcons.record
        from demo_data_gen import generate
        from inspector.recording import write_recording
        from radcons.params import Params
        from radcons.pipeline import Pipeline

        run = Pipeline(Params.from_preset("paper")).run(generate(size=96, seed=0, scenario="mixed"), until="objects")
        log_run = radcons.record.log_run

        def slow(*args, **kwargs):
            log_run(*args, **kwargs)
            print("logged", flush=True)
            time.sleep(600)

        radcons.record.log_run = slow
        write_recording({str(folder)!r}, "pair", [(0, run), (1, run)])
        """
    )
    process = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert process.stdout.readline().strip() == "logged"
        os.kill(process.pid, signal.SIGKILL)
        process.wait(60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    left = list(folder.iterdir())
    assert [path.suffix for path in left] == [".part"] and not any(path.name.endswith(".rrd") for path in left)
    path = write_recording(folder, "pair", [(0, run)])
    assert [p.name for p in folder.iterdir()] == [path.name]
    assert _rrd_readable(path)


def test_an_interrupted_parameter_export_leaves_no_file(tmp_path, monkeypatch):
    """The Export tab's parameter file goes through an atomic rename: interrupted before it,
    no file (not half of one) is there."""
    import radcons.io.atomic as atomic

    from inspector.context import Context
    from inspector.panels.export import ExportPanel
    from inspector.state import Session

    context = Context()
    context.session = Session(params=Params())
    sent = []
    context.notify = lambda client, title, body, error=True: sent.append(title)
    panel = ExportPanel(context, tmp_path / "rec")
    panel.info = SimpleNamespace(content="")

    def interrupted(source, destination):
        raise KeyboardInterrupt

    monkeypatch.setattr(atomic.os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        panel.on_export(SimpleNamespace(client=None))
    assert list((tmp_path / "rec").iterdir()) == []
    monkeypatch.undo()
    panel.on_export(SimpleNamespace(client=None))
    assert sent == ["Parameters exported"] and Params.load(panel.last_export) == Params()
    for worker in context.workers:
        worker.stop()


@pytest.mark.parametrize("matcher", ["sgbm", "census"])
def test_a_recorded_review_names_the_matcher_it_was_measured_with(run, matcher):
    from inspector.panels.export import ExportPanel
    from inspector.review import Review
    from radcons.evaluate.matching import MATCHERS

    original = SimpleNamespace(name="original")
    review = Review("global", SimpleNamespace(name="global"), (original,), (0.0, 8.0), None, matcher)
    comparison = ExportPanel._comparison(run, review)
    assert type(comparison.matcher) is MATCHERS[matcher]
    assert [m.name for m in comparison.methods] == ["original", "global"]
