"""The ``radcons`` command line: ``demo``, ``process``, ``evaluate``, ``inspect``, ``view``, ``params``.

Heavy libraries (OpenCV, viser, rerun) are imported inside the subcommands, so that
``radcons --help`` answers at once. Every input is checked before any compute
(:mod:`radcons.preflight`, :mod:`radcons.validate`). Errors caused by the input print one
line (``radcons: error: <file>: <problem>``) and exit with status 2; any other failure
prints one line (``radcons: failed: ...``) and exits with status 1; ``--debug`` shows the
traceback instead.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Sequence

from radcons.errors import RadconsError
from radcons.stages import STAGES

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of the ``radcons`` command.

    Returns
    -------
    argparse.ArgumentParser
        The top-level parser, with one subcommand each for ``demo``, ``process``,
        ``evaluate``, ``inspect``, ``view`` and ``params``; every parser takes ``--debug``.
    """
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", help="show the full traceback of an error")
    parser = argparse.ArgumentParser(
        prog="radcons",
        description="Radiometric consistency for mixed satellite stereo pairs (Su et al. 2018).",
        parents=[common],
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str, text: str) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=text, parents=[common])

    _add_demo_arguments(add("demo", "generate a synthetic urban stereo pair with ground truth"))
    _add_process_arguments(add("process", "make a pair radiometrically consistent"))
    _add_evaluate_arguments(add("evaluate", "compare the method with baselines by dense matching"))
    _add_inspect_arguments(add("inspect", "start the browser inspector"))
    _add_view_arguments(add("view", "open a rerun recording in the rerun web viewer (127.0.0.1)"))
    _add_params_arguments(add("params", "write the default parameters as TOML"))
    return parser


def _add_demo_arguments(demo: argparse.ArgumentParser) -> None:
    """Add the arguments of ``radcons demo``.

    Parameters
    ----------
    demo : argparse.ArgumentParser
        The subcommand's parser, changed in place.
    """
    demo.add_argument("out", type=Path, help="output pair folder")
    demo.add_argument("--size", type=int, default=512, help="image side in pixels (default 512)")
    demo.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    demo.add_argument(
        "--scenario",
        default="mixed",
        choices=("none", "multi-temporal", "multi-sensor", "mixed"),
        help="what differs between the two images (default mixed)",
    )


def _add_process_arguments(process: argparse.ArgumentParser) -> None:
    """Add the arguments of ``radcons process``: the pair, outputs, recording and scene mode.

    Parameters
    ----------
    process : argparse.ArgumentParser
        The subcommand's parser, changed in place.
    """
    _add_pair_arguments(process)
    process.add_argument("--out", type=Path, required=True, help="output pair folder")
    process.add_argument("--params", type=Path, help="parameter TOML (as written by `radcons params`)")
    process.add_argument("--preset", help="start from a preset (radcons, paper); default radcons")
    process.add_argument("--until", choices=STAGES, metavar="STAGE", help=f"last stage to run ({', '.join(STAGES)})")
    process.add_argument(
        "--output-dtype",
        choices=("own", "common"),
        default="own",
        help="pairs of two bit depths: each image in its own dtype and range (default), or both in the wider dtype",
    )
    process.add_argument(
        "--original-geometry",
        action="store_true",
        help="for an unrectified pair: write the consistent images back in the input's geometry",
    )
    process.add_argument("--rrd", type=Path, help="also write a rerun recording of every stage")
    process.add_argument(
        "--matcher",
        default="sgbm",
        help="dense matcher of the recording's per-stage disparity: sgbm (default, fast) or census",
    )
    process.add_argument("--full-resolution", action="store_true", help="record images at full resolution")
    process.add_argument("--quiet", action="store_true", help="no progress on stderr")
    process.add_argument(
        "--memory-limit", metavar="SIZE",
        help="memory the run may use, e.g. 8G (default: half the available memory); a larger pair runs in scene mode",
    )
    process.add_argument(
        "--tiles", type=int, nargs="?", const=1024, metavar="SIZE",
        help="force scene mode: tiles of SIZE px (a multiple of 64, default 1024) on a Dask cluster, bounded memory",
    )
    process.add_argument("--scheduler", metavar="ADDRESS", help="scene mode on the Dask scheduler at ADDRESS (tcp://host:port)")


def _add_evaluate_arguments(evaluate: argparse.ArgumentParser) -> None:
    """Add the arguments of ``radcons evaluate``: the pair, methods, matchers and outputs.

    Parameters
    ----------
    evaluate : argparse.ArgumentParser
        The subcommand's parser, changed in place.
    """
    _add_pair_arguments(evaluate)
    evaluate.add_argument(
        "--methods",
        default="original,histmatch,irmad,zhang,zhong,ours",
        help="comma-separated methods (default: original,histmatch,irmad,zhang,zhong,ours)",
    )
    evaluate.add_argument(
        "--matcher",
        default="sgbm,census",
        help="comma-separated dense matchers: sgbm (OpenCV), census (CNES Pandora); default both",
    )
    evaluate.add_argument("--params", type=Path, help="parameter TOML for 'ours'")
    evaluate.add_argument("--preset", help="preset for 'ours' (radcons, paper); default radcons")
    evaluate.add_argument("--json", type=Path, help="write the results as JSON")
    evaluate.add_argument("--rrd", type=Path, help="also write a rerun recording")
    evaluate.add_argument("--full-resolution", action="store_true", help="record images at full resolution")
    evaluate.add_argument("--quiet", action="store_true", help="no progress on stderr")


def _add_inspect_arguments(inspect: argparse.ArgumentParser) -> None:
    """Add the arguments of ``radcons inspect``: pairs, server address and memory budget.

    Parameters
    ----------
    inspect : argparse.ArgumentParser
        The subcommand's parser, changed in place.
    """
    inspect.add_argument("pairs", nargs="*", type=Path, help="pair folders, or a reference and a target image")
    inspect.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    inspect.add_argument(
        "--port", type=int, help="port, which must be free (0: any free port); default 8080 or the next free one"
    )
    inspect.add_argument("--band", type=int, help="1-based band of multiband images (default: RGB luminance, else the mean of the bands)")
    add_geometry_arguments(inspect)
    inspect.add_argument("--data-root", type=Path, action="append", default=[], help="folder whose pairs may be loaded")
    inspect.add_argument("--record-dir", type=Path, default=Path("recordings"), help="where recordings go")
    inspect.add_argument("--rerun-web", action="store_true", help="serve a rerun web viewer that follows the tuning")
    inspect.add_argument(
        "--memory-limit", metavar="SIZE",
        help="memory budget, e.g. 8G (default: half the available memory): a larger pair opens as a scene "
        "preview, and whole-scene runs stay within it",
    )


def _add_view_arguments(view: argparse.ArgumentParser) -> None:
    """Add the arguments of ``radcons view``: the recording and the viewer's port.

    Parameters
    ----------
    view : argparse.ArgumentParser
        The subcommand's parser, changed in place.
    """
    view.add_argument("recording", type=Path, help=".rrd file")
    view.add_argument("--port", type=int, default=9090, help="web viewer port (default 9090)")


def _add_params_arguments(params: argparse.ArgumentParser) -> None:
    """Add the arguments of ``radcons params``: the output file and the preset.

    Parameters
    ----------
    params : argparse.ArgumentParser
        The subcommand's parser, changed in place.
    """
    params.add_argument("out", type=Path, nargs="?", help="output file (default: print)")
    params.add_argument("--preset", help="preset to start from (radcons, paper); default radcons")


def _add_pair_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("pair", type=Path, nargs="+", metavar="PAIR", help="a pair folder, or a reference and a target image")
    parser.add_argument("--nodata", type=float, help="nodata value (two-image form)")
    parser.add_argument("--band", type=int, help="1-based band of multiband images (default: RGB luminance, else the mean of the bands)")
    add_geometry_arguments(parser)
    parser.add_argument(
        "--keep-rows", action="store_true",
        help="leave a rectified pair's target as it is (default: its vertical offset, when over 0.5 px, is taken out)",
    )


def add_geometry_arguments(parser: argparse.ArgumentParser) -> None:
    """``--rectified`` / ``--unrectified``: force how a pair's geometry is taken.

    Without either, two images of different sizes are unrectified and equal sizes rectified;
    a pair folder's ``rectified`` key always wins.
    """
    geometry = parser.add_mutually_exclusive_group()
    geometry.add_argument(
        "--rectified", dest="rectified", action="store_const", const=True, default=None,
        help="the images are an epipolar-rectified pair (rows correspond)",
    )
    geometry.add_argument(
        "--unrectified", dest="rectified", action="store_const", const=False,
        help="the images are not epipolar-rectified (they are resampled first)",
    )


def _load(args: argparse.Namespace):
    from radcons.geometry import settle_geometry
    from radcons.io import load_pair, load_pair_files

    if len(args.pair) == 1:
        pair = load_pair(args.pair[0], band=args.band, rectified=args.rectified)
    elif len(args.pair) == 2:
        pair = load_pair_files(args.pair[0], args.pair[1], nodata=args.nodata, rectified=args.rectified, band=args.band)
    else:
        raise RadconsError("give one pair folder or two image files (reference, target)")
    return settle_geometry(pair, level=not args.keep_rows)


def _load_params(path: Path | None, preset: str | None):
    """Parameters from a TOML file (its ``preset`` key names its start) or a preset."""
    from radcons.params import DEFAULT_PRESET, Params

    if path is not None:
        if preset is not None:
            raise RadconsError("give --params or --preset, not both (a parameter file names its preset)")
        return Params.load(path)
    return Params.from_preset(preset or DEFAULT_PRESET)


class _Progress:
    """Pipeline progress on stderr: a tqdm bar on a terminal, one line per stage otherwise.

    A log file gets ``radcons: stage 3/8 association`` lines instead of the bar's
    carriage-return redraws.
    """

    def __init__(self, quiet: bool) -> None:
        self._quiet = quiet
        self._bar = None
        if not quiet and sys.stderr.isatty():
            from tqdm import tqdm

            self._bar = tqdm(total=len(STAGES), desc="radcons", unit="stage", file=sys.stderr, leave=False)

    def __call__(self, stage: str, index: int, count: int) -> None:
        if self._quiet:
            return
        if self._bar is None:
            print(f"radcons: stage {index + 1}/{count} {stage}", file=sys.stderr, flush=True)
            return
        self._bar.total = count
        self._bar.n = index
        self._bar.set_description(stage)
        self._bar.refresh()

    def close(self) -> None:
        """Remove the bar (terminal) once the run ends."""
        if self._bar is not None:
            self._bar.close()


def _preflight(args: argparse.Namespace) -> tuple[list[Path], Any]:
    """Check paths, sizes, memory, options and parameters before anything is computed.

    Returns every input file and the parameters.
    """
    from radcons import preflight

    if len(args.pair) not in (1, 2):
        raise RadconsError("give one pair folder or two image files (reference, target)")
    preflight.check_params_file(args.params)
    params = _load_params(args.params, args.preset)
    inputs, folder = preflight.input_files(args.pair)
    images = preflight.image_files(args.pair)
    headers = preflight.headers_of(images)
    preflight.check_sizes(headers, images)
    preflight.check_nodata(args.nodata, headers, images)
    if _scene_mode(args, headers):
        needed = 0  # run_scene checks the disk once it has seen that the images are not blank
    else:
        preflight.check_memory(headers, images)
        needed = preflight.output_bytes(headers)
    if getattr(args, "out", None) is not None:
        preflight.check_output_folder(args.out, inputs, folder, needed)
    for name in ("rrd", "json"):
        path = getattr(args, name, None)
        if path is not None:
            preflight.check_output_file(path, inputs, f"--{name}")
    return inputs, params


def _scene_mode(args: argparse.Namespace, headers: Sequence[Any]) -> bool:
    """Whether ``process`` runs in scene mode: asked for, or the pair passes the memory budget."""
    from radcons import preflight

    if getattr(args, "command", None) != "process":
        return False
    preflight.check_scene_options(args.tiles, args.scheduler)
    budget = preflight.memory_budget(args.memory_limit)
    args.scene = args.tiles is not None or args.scheduler is not None or preflight.needs_scene(headers, budget)
    args.memory_bytes = budget
    if args.scene and (args.rrd is not None or args.original_geometry):
        raise RadconsError("--rrd and --original-geometry are not available in scene mode")
    return args.scene


def _cmd_scene(args: argparse.Namespace, params: Any) -> int:
    """``process`` in scene mode: :func:`radcons.scene.run_scene` with progress on stderr."""
    from radcons.scene import DEFAULT_TILE, SceneOptions, open_scene_pair, run_scene

    pair = open_scene_pair(args.pair, nodata=args.nodata, band=args.band, rectified=args.rectified)
    options = SceneOptions(
        tile=DEFAULT_TILE if args.tiles is None else args.tiles, scheduler=args.scheduler,
        memory_limit=args.memory_bytes, level_rows=not args.keep_rows,
    )

    def progress(step: str, done: Any, total: int) -> None:
        if args.quiet:
            return
        if step == "dashboard":
            print(f"radcons: scene mode, Dask dashboard: {done or 'none served by the scheduler'}", file=sys.stderr, flush=True)
        elif step != "tiles" or done == total or done % max(1, total // 20) == 0:
            print(f"radcons: scene {step} {done}/{total}", file=sys.stderr, flush=True)

    result = run_scene(pair, args.out, params, options, until=args.until, output_dtype=args.output_dtype, progress=progress)
    if not args.quiet:
        print(f"wrote {result.manifest.parent} (scene mode, {result.summary['tiles']} tiles, "
              f"{result.summary['timings_s']['total']:.1f}s)")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from demo_data_gen import generate
    from radcons.io import save_pair

    pair = generate(size=args.size, seed=args.seed, scenario=args.scenario)
    manifest = save_pair(pair, args.out)
    print(f"demo pair ({args.scenario}, {args.size}x{args.size}, seed {args.seed}) written to {manifest.parent}")
    return 0


def _cmd_process(args: argparse.Namespace) -> int:
    _, params = _preflight(args)
    if getattr(args, "scene", False):
        return _cmd_scene(args, params)
    matchers = _matchers(args.matcher)
    if len(matchers) != 1:
        raise RadconsError(f"--matcher {args.matcher!r}: a recording's stage disparities use one matcher")
    pair = _load(args)
    from radcons.pipeline import Pipeline
    from radcons.summary import write_outputs

    progress = _Progress(args.quiet)
    try:
        run = Pipeline(params).run(pair, until=args.until, progress=progress)
    finally:
        progress.close()
    manifest = write_outputs(run, args.out, original_geometry=args.original_geometry, output_dtype=args.output_dtype)
    if args.rrd is not None:
        from radcons.record import save_recording

        save_recording(run, args.rrd, full_resolution=args.full_resolution, matcher=matchers[0])
    if not args.quiet:
        times = ", ".join(f"{name} {seconds:.2f}s" for name, seconds in run.timings.items())
        print(f"wrote {manifest.parent} ({times})")
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    _, params = _preflight(args)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    from radcons.workflow import METHODS

    unknown = [m for m in methods if m not in METHODS]
    if unknown or not methods:
        raise RadconsError(f"unknown method(s) {', '.join(unknown) or '(none given)'} (known: {', '.join(METHODS)})")
    matchers = _matchers(args.matcher)
    pair = _load(args)
    from radcons.workflow import evaluate_pair_matchers, ours_noise_notice

    progress = _Progress(args.quiet)
    try:
        run, evaluation = evaluate_pair_matchers(pair, methods, params, matchers, progress=progress)
    finally:
        progress.close()
    print(evaluation.format_table())
    notice = ours_noise_notice(run, evaluation)
    if notice is not None:
        print(f"\n{notice}")
    if args.json is not None:
        from radcons.io import atomic_write_bytes

        atomic_write_bytes(args.json, json.dumps({**evaluation.to_json_dict(), "noise_notice": notice}, indent=2).encode())
    if args.rrd is not None:
        from radcons.record import save_recording

        save_recording(
            run, args.rrd, comparison=evaluation.first, full_resolution=args.full_resolution, matcher=matchers[0]
        )
    return 0


def _matchers(text: str) -> list[Any]:
    """The dense matchers named in a comma-separated ``--matcher`` value, with their defaults."""
    from radcons.evaluate.matching import MATCHERS, matcher_params

    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in MATCHERS]
    if unknown or not names or len(set(names)) != len(names):
        raise RadconsError(
            f"--matcher {text!r}: give distinct matchers among {', '.join(MATCHERS)}"
            + (f" (unknown: {', '.join(unknown)})" if unknown else "")
        )
    return [matcher_params(name) for name in names]


def _cmd_inspect(args: argparse.Namespace) -> int:
    from inspector.serve import serve

    return serve(args)


def _cmd_view(args: argparse.Namespace) -> int:
    from radcons.record import view_recording

    return view_recording(args.recording, port=args.port)


def _cmd_params(args: argparse.Namespace) -> int:
    params = _load_params(None, args.preset)
    if args.out is None:
        sys.stdout.write(params.to_toml())
    else:
        from radcons import preflight

        preflight.check_params_output(args.out)
        params.save(args.out)
        print(f"parameters written to {args.out}")
    return 0


_COMMANDS: dict[str, Any] = {
    "demo": _cmd_demo,
    "process": _cmd_process,
    "evaluate": _cmd_evaluate,
    "inspect": _cmd_inspect,
    "view": _cmd_view,
    "params": _cmd_params,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``radcons`` command; returns the exit status.

    0 on success, 2 for a bad input (one line naming the file and the problem), 1 for any
    other failure (one line; ``--debug`` re-raises it with its traceback), 130 when
    interrupted.
    """
    args = build_parser().parse_args(argv)
    try:
        return _COMMANDS[args.command](args)
    except RadconsError as exc:
        if args.debug:
            raise
        print(f"radcons: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("radcons: interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        if args.debug:
            raise
        print("radcons: failed: out of memory; process a smaller crop of the pair", file=sys.stderr)
        return 1
    except Exception as exc:  # noqa: BLE001 - the one place that turns failures into one line
        if args.debug:
            raise
        where = f"{exc.filename}: " if isinstance(exc, OSError) and exc.filename else ""
        detail = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc) or type(exc).__name__
        print(f"radcons: failed: {where}{detail} (run with --debug for the traceback)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
