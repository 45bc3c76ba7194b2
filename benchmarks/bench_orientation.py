"""Which way up the affine route turns a pair: the rotation rule against the relief rule.

Every pair goes through the affine route (``RectifyParams(method="affine")``, its RPC
models unused) and is measured by :func:`radcons.stages.rectify.orientation.relief_skew`
as the rotation rule turned it. Whether it is the right way up (higher points with larger
disparities) is read from its RPC models where it has them (the disparity at the
reference's centre for a point 50 m and 150 m high, located with shareloc; unknown for
Mont Ventoux, whose ``.geom`` files hold a physical sensor model), or, for a
pair given rectified (US3D, La Reunion, the demo pairs: their disparity already grows
with height), from the rotation the route applied (under 90 deg keeps that orientation).

Two sets: the real pairs of ``../shared/data`` (the threshold was set on them, with the
demo pairs ``mixed`` seed 0 and ``multi-temporal`` seed 5 at 1024 px), and demo pairs the
threshold never saw (``--seeds``, three scenarios, 512 px), each also with both images
turned by 180 deg, which the rotation rule then gives back upside down.

Run: ``nice .venv/bin/python benchmarks/bench_orientation.py [--seeds 0 1 2 3 4]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from radcons.io import load_pair_files
from radcons.pipeline import pair_images
from radcons.rpc import pair_rpcs
from radcons.stages.rectify.run import Rectification, RectifyParams, rectify_pair
from radcons.stages.rectify.orientation import ORIENTATION_SKEW, relief_skew
from radcons.stages.rectify.rpc import _shareloc_model

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
ROTATION = RectifyParams(method="affine", orient="rotation")


def _real_pairs() -> dict[str, tuple[Path, Path]]:
    kah = DATA / "pleiades_kahramanmaras_prepost"
    jax = DATA / "us3d_jacksonville_multidate"
    return {
        "Pleiades Gizeh": (DATA / "pleiades_gizeh" / "img1.tif", DATA / "pleiades_gizeh" / "img2.tif"),
        "Pleiades Kahramanmaras pre1/pre2": (next(kah.glob("pre_event_img1*.tif")), next(kah.glob("pre_event_img2*.tif"))),
        "Pleiades Kahramanmaras post1/post2": (next(kah.glob("post_event_img1*.tif")), next(kah.glob("post_event_img2*.tif"))),
        "Pleiades Kahramanmaras pre1/post1": (next(kah.glob("pre_event_img1*.tif")), next(kah.glob("post_event_img1*.tif"))),
        "Pleiades Mont Ventoux": (DATA / "pleiades_ventoux" / "left_image.tif", DATA / "pleiades_ventoux" / "right_image.tif"),
        "Pleiades La Reunion (given rectified)": (DATA / "pleiades_reunion_rectified" / "a.tif", DATA / "pleiades_reunion_rectified" / "b.tif"),
        "WorldView-3 JAX_072 (given rectified)": (jax / "JAX_072_011_022_LEFT_RGB.tif", jax / "JAX_072_011_022_RIGHT_RGB.tif"),
        "WorldView-3 JAX_122 (given rectified)": (jax / "JAX_122_019_005_LEFT_RGB.tif", jax / "JAX_122_019_005_RIGHT_RGB.tif"),
    }


def _up_by_rpc(rectification: Rectification, rpcs, shape: tuple[int, int]) -> bool:
    """Whether the rectified disparity at the reference's centre grows with height (RPC models, shareloc)."""
    ref_rpc, tgt_rpc = rpcs
    heights = np.array([50.0, 150.0])
    row = np.full(2, shape[0] / 2.0 + ref_rpc.crop_offset[1] + 0.5)
    col = np.full(2, shape[1] / 2.0 + ref_rpc.crop_offset[0] + 0.5)
    ground = _shareloc_model(ref_rpc).direct_loc_h(row, col, heights)
    ref_col, ref_row = ref_rpc.project(ground[:, 0], ground[:, 1], heights)
    tgt_col, tgt_row = tgt_rpc.project(ground[:, 0], ground[:, 1], heights)
    ref_x = rectification.ref_transform[0] @ np.vstack([ref_col, ref_row, np.ones(2)])
    tgt_x = rectification.tgt_transform[0] @ np.vstack([tgt_col, tgt_row, np.ones(2)])
    disparity = ref_x - tgt_x
    return bool(disparity[1] > disparity[0])


def _row(name: str, reference: np.ndarray, target: np.ndarray, up_of) -> tuple[bool, bool] | None:
    """Print one pair's row; return whether the rotation rule and the relief rule put it right way up (None: unknown)."""
    rectification = rectify_pair(reference, target, ROTATION)
    skew = relief_skew(rectification.reference, rectification.target, rectification.disparity_range)
    turned = skew < -ORIENTATION_SKEW
    rotation_up = up_of(rectification)
    if rotation_up is None:
        print(f"| {name} | {skew:+.2f} | unknown (no RPC model) | {'turned' if turned else 'kept'} |", flush=True)
        return None
    relief_up = rotation_up != turned
    print(f"| {name} | {skew:+.2f} | {'yes' if rotation_up else 'no'} | {'yes' if relief_up else 'no'} |", flush=True)
    return rotation_up, relief_up


def _header(title: str) -> None:
    print(f"\n## {title}\n")
    print("| pair | relief skew (as the rotation rule turned it) | right way up: rotation rule | relief rule |")
    print("| --- | --- | --- | --- |")


def _total(results: list[tuple[bool, bool] | None]) -> None:
    results = [r for r in results if r is not None]
    rotation, relief = (sum(r[k] for r in results) for k in (0, 1))
    print(f"\nright way up: rotation rule {rotation} of {len(results)}, relief rule {relief} of {len(results)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3, 4, 6])
    parser.add_argument("--scenarios", nargs="+", default=["mixed", "multi-sensor", "multi-temporal"])
    parser.add_argument("--size", type=int, default=512)
    args = parser.parse_args()
    print(f"relief rule: turned by 180 deg when the relief skew is below -{ORIENTATION_SKEW:g}")
    results: list[tuple[bool, bool] | None] = []
    if DATA.is_dir():
        _header("real pairs (the threshold was set on these)")
        for name, files in _real_pairs().items():
            given = "given rectified" in name
            pair = load_pair_files(*files, rectified=False)
            reference, target = pair_images(pair)
            rpcs, _ = pair_rpcs(pair.reference, pair.target)
            if given:
                up_of = lambda r: bool(r.ref_transform[0, 0] > 0)  # noqa: E731
            elif rpcs is None:  # Mont Ventoux: a physical sensor model, which radcons does not read
                up_of = lambda r: None  # noqa: E731
            else:
                up_of = lambda r, rpcs=rpcs, shape=reference.shape: _up_by_rpc(r, rpcs, shape)  # noqa: E731
            results.append(_row(name, reference, target, up_of))
        _total(results)
    from demo_data_gen import generate

    _header(f"demo pairs the threshold never saw ({args.size} px; each also turned by 180 deg)")
    results = []
    for scenario in args.scenarios:
        for seed in args.seeds:
            pair = generate(size=args.size, seed=seed, scenario=scenario)
            reference, target = pair.reference.as_float32(), pair.target.as_float32()
            results.append(_row(f"{scenario} seed {seed}", reference, target, lambda r: bool(r.ref_transform[0, 0] > 0)))
            results.append(
                _row(
                    f"{scenario} seed {seed}, turned", reference[::-1, ::-1].copy(), target[::-1, ::-1].copy(),
                    lambda r: bool(r.ref_transform[0, 0] < 0),
                )
            )
    _total(results)


if __name__ == "__main__":
    main()
