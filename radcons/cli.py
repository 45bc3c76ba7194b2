"""The ``radcons`` command line: ``demo``, ``process``, ``evaluate``, ``inspect``, ``view``, ``params``.

Heavy libraries (OpenCV, viser, rerun) are imported inside the subcommands, so that
``radcons --help`` answers at once. Errors caused by the input print one line
(``radcons: error: <file>: <problem>``) and exit with status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Sequence

from radcons.errors import RadconsError

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of the ``radcons`` command."""
    parser = argparse.ArgumentParser(
        prog="radcons",
        description="Radiometric consistency for mixed satellite stereo pairs (Su et al. 2018).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="generate a synthetic urban stereo pair with ground truth")
    demo.add_argument("out", type=Path, help="output pair folder")
    demo.add_argument("--size", type=int, default=512, help="image side in pixels (default 512)")
    demo.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    demo.add_argument(
        "--scenario",
        default="mixed",
        choices=("none", "multi-temporal", "multi-sensor", "mixed"),
        help="what differs between the two images (default mixed)",
    )

    process = sub.add_parser("process", help="make a pair radiometrically consistent")
    _add_pair_arguments(process)
    process.add_argument("--out", type=Path, required=True, help="output pair folder")
    process.add_argument("--params", type=Path, help="parameter TOML (as written by `radcons params`)")
    process.add_argument("--preset", help="start from a preset (radcons, paper); default radcons")
    process.add_argument("--until", help="last stage to run (objects, association, uniformity, global, refine, smoothness)")
    process.add_argument(
        "--original-geometry",
        action="store_true",
        help="for an unrectified pair: write the consistent images back in the input's geometry",
    )
    process.add_argument("--rrd", type=Path, help="also write a rerun recording of every stage")
    process.add_argument("--full-resolution", action="store_true", help="record images at full resolution")
    process.add_argument("--quiet", action="store_true", help="no progress on stderr")

    evaluate = sub.add_parser("evaluate", help="compare the method with baselines by dense matching")
    _add_pair_arguments(evaluate)
    evaluate.add_argument(
        "--methods",
        default="original,histmatch,irmad,zhang,zhong,ours",
        help="comma-separated methods (default: original,histmatch,irmad,zhang,zhong,ours)",
    )
    evaluate.add_argument("--params", type=Path, help="parameter TOML for 'ours'")
    evaluate.add_argument("--preset", help="preset for 'ours' (radcons, paper); default radcons")
    evaluate.add_argument("--json", type=Path, help="write the results as JSON")
    evaluate.add_argument("--rrd", type=Path, help="also write a rerun recording")
    evaluate.add_argument("--full-resolution", action="store_true", help="record images at full resolution")
    evaluate.add_argument("--quiet", action="store_true", help="no progress on stderr")

    inspect = sub.add_parser("inspect", help="start the browser inspector")
    inspect.add_argument("pairs", nargs="*", type=Path, help="pair folders, or a reference and a target image")
    inspect.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    inspect.add_argument("--port", type=int, default=8080, help="port (default 8080; the next free one is taken)")
    inspect.add_argument("--data-root", type=Path, action="append", default=[], help="folder whose pairs may be loaded")
    inspect.add_argument("--record-dir", type=Path, default=Path("recordings"), help="where recordings go")
    inspect.add_argument("--rerun-web", action="store_true", help="serve a rerun web viewer that follows the tuning")

    view = sub.add_parser("view", help="open a rerun recording in the rerun web viewer (127.0.0.1)")
    view.add_argument("recording", type=Path, help=".rrd file")
    view.add_argument("--port", type=int, default=9090, help="web viewer port (default 9090)")

    params = sub.add_parser("params", help="write the default parameters as TOML")
    params.add_argument("out", type=Path, nargs="?", help="output file (default: print)")
    params.add_argument("--preset", help="preset to start from (radcons, paper); default radcons")
    return parser


def _add_pair_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("pair", type=Path, nargs="+", metavar="PAIR", help="a pair folder, or a reference and a target image")
    parser.add_argument("--nodata", type=float, help="nodata value (two-image form)")
    parser.add_argument("--unrectified", action="store_true", help="the two images are not epipolar-rectified (they are resampled first)")


def _load(args: argparse.Namespace):
    from radcons.io import load_pair, load_pair_files

    if len(args.pair) == 1:
        return load_pair(args.pair[0])
    if len(args.pair) == 2:
        return load_pair_files(args.pair[0], args.pair[1], nodata=args.nodata, rectified=not args.unrectified)
    raise RadconsError("give one pair folder or two image files (reference, target)")


def _load_params(path: Path | None, preset: str | None):
    """Parameters from a TOML file (its ``preset`` key names its start) or a preset."""
    from radcons.params import DEFAULT_PRESET, Params

    if path is not None:
        if preset is not None:
            raise RadconsError("give --params or --preset, not both (a parameter file names its preset)")
        return Params.load(path)
    return Params.from_preset(preset or DEFAULT_PRESET)


def _progress(quiet: bool, total: int):
    """Return a pipeline progress callback drawing a tqdm bar on stderr, and the bar."""
    from tqdm import tqdm

    bar = tqdm(total=total, desc="radcons", unit="stage", disable=quiet, file=sys.stderr, leave=False)

    def callback(stage: str, index: int, count: int) -> None:
        bar.total = count
        bar.n = index
        bar.set_description(stage)
        bar.refresh()

    return callback, bar


def _cmd_demo(args: argparse.Namespace) -> int:
    from demo_data_gen import generate
    from radcons.io import save_pair

    pair = generate(size=args.size, seed=args.seed, scenario=args.scenario)
    manifest = save_pair(pair, args.out)
    print(f"demo pair ({args.scenario}, {args.size}x{args.size}, seed {args.seed}) written to {manifest.parent}")
    return 0


def _cmd_process(args: argparse.Namespace) -> int:
    pair = _load(args)
    from radcons.pipeline import Pipeline
    from radcons.summary import write_outputs

    params = _load_params(args.params, args.preset)
    callback, bar = _progress(args.quiet, 6)
    try:
        run = Pipeline(params).run(pair, until=args.until, progress=callback)
    finally:
        bar.close()
    manifest = write_outputs(run, args.out, original_geometry=args.original_geometry)
    if args.rrd is not None:
        from radcons.record import save_recording

        save_recording(run, args.rrd, full_resolution=args.full_resolution)
    if not args.quiet:
        times = ", ".join(f"{name} {seconds:.2f}s" for name, seconds in run.timings.items())
        print(f"wrote {manifest.parent} ({times})")
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    pair = _load(args)
    from radcons.workflow import evaluate_pair

    params = _load_params(args.params, args.preset)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    callback, bar = _progress(args.quiet, 6)
    try:
        run, comparison = evaluate_pair(pair, methods, params, progress=callback)
    finally:
        bar.close()
    print(comparison.format_table())
    if args.json is not None:
        from radcons.io import atomic_write_bytes

        atomic_write_bytes(args.json, json.dumps(comparison.to_json_dict(), indent=2).encode("utf-8"))
    if args.rrd is not None:
        from radcons.record import save_recording

        save_recording(run, args.rrd, comparison=comparison, full_resolution=args.full_resolution)
    return 0


def _cmd_inspect(args: argparse.Namespace) -> int:
    from inspector.app import serve

    return serve(args)


def _cmd_view(args: argparse.Namespace) -> int:
    from radcons.record import view_recording

    return view_recording(args.recording, port=args.port)


def _cmd_params(args: argparse.Namespace) -> int:
    import tomli_w

    params = _load_params(None, args.preset)
    if args.out is None:
        sys.stdout.write(tomli_w.dumps(params.to_dict()))
    else:
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
    """Entry point of the ``radcons`` command; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return _COMMANDS[args.command](args)
    except RadconsError as exc:
        print(f"radcons: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("radcons: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
