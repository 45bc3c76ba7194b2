"""Writing a run to an ``.rrd`` file, atomically, with the default blueprint."""

from __future__ import annotations

import os
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator

import rerun as rr

from radcons.errors import InputError
from radcons.evaluate.compare import Comparison
from radcons.evaluate.matching import MatcherParams
from radcons.numerics.census import CensusParams
from radcons.pipeline import Run
from radcons.record.layout import default_blueprint
from radcons.record.log import log_run
from radcons.record.stage_review import review_stages

__all__ = ["APPLICATION_ID", "recording_file", "save_recording"]

APPLICATION_ID = "radcons"


def save_recording(
    run: Run,
    path: str | Path,
    comparison: Comparison | None = None,
    full_resolution: bool = False,
    matcher: MatcherParams | CensusParams | None = None,
) -> Path:
    """Write a run (and its comparison of methods) as a rerun recording.

    The file is written to a temporary file in the destination folder, completed (the
    recording is disconnected, which flushes it and writes its footer), synced to disk and
    then renamed over ``path``, so an interrupted write leaves no half file.

    Parameters
    ----------
    run : Run
        A finished pipeline run.
    path : str or Path
        Destination ``.rrd`` file; its folder is created if needed.
    comparison : Comparison, optional
        Measurements of compared methods (disparity review and metrics).
    full_resolution : bool
        Log images at full resolution even above the preview size.
    matcher : MatcherParams or CensusParams, optional
        Match every image stage's pair with this matcher and log its disparity (error map
        and rates with ground truth) on the ``stage`` timeline, shown beside the images
        (:func:`radcons.record.stage_review.review_stages`). None: no stage disparity.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InputError
        The destination cannot be written, or what :func:`log_run` raises.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the folder of the recording ({exc.strerror or exc})", path) from exc
    methods = [m.name for m in comparison.methods] if comparison is not None else []
    review = review_stages(run, matcher) if matcher is not None else None
    blueprint = default_blueprint(
        methods,
        stage_disparity=review is not None and bool(review.stages),
        stage_error=review is not None and bool(review.stages) and review.truth is not None,
    )
    with recording_file(path, run.pair.name, blueprint) as rec:
        log_run(run, rec, comparison, full_resolution=full_resolution, stage_review=review)
    return path


@contextmanager
def recording_file(path: Path, name: str, blueprint: Any) -> Iterator[rr.RecordingStream]:
    """A recording stream saved to ``path`` whole or not at all.

    The stream writes to a hidden partial file beside ``path``
    (``.<file name>.<random>.<pid>.part``, so a folder's owner can tell the partial files of
    processes killed while writing from those of running ones). When the ``with`` block
    ends normally the stream is disconnected (which flushes it and writes its footer), the
    file is synced to disk and renamed over ``path``; when it raises, the partial file is
    removed and the exception goes on.

    Parameters
    ----------
    path : Path
        Destination ``.rrd`` file; its folder must exist.
    name : str
        The recording's name, shown by the viewer.
    blueprint : rerun blueprint
        The default blueprint saved with it.

    Yields
    ------
    rerun.RecordingStream
        The stream to log into (no log tick or log time timelines).

    Raises
    ------
    InputError
        The partial file cannot be created.
    """
    partial = path.parent / f".{path.name}.{uuid.uuid4().hex[:12]}.{os.getpid()}.part"
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=str(uuid.uuid4()))
    rec.set_log_tick_enabled(False)
    rec.set_log_time_enabled(False)
    try:
        try:
            rec.save(partial, default_blueprint=blueprint)
        except RuntimeError as exc:  # rerun reports a file it cannot create this way
            raise InputError(f"cannot write the recording ({exc})", path) from exc
        rec.send_recording_name(name)
        yield rec
        rec.disconnect()
        with partial.open("rb") as handle:
            os.fsync(handle.fileno())
        os.replace(partial, path)
    except BaseException:
        rec.disconnect()
        partial.unlink(missing_ok=True)
        raise
