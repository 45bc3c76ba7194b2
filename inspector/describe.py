"""What the Data tab says about a pair: how its grey bands were made, whether it is taken as
epipolar-rectified and why, how its epipolar resampling went, a noise ratio its run
leaves above 1.5, and whether its refine stage corrected light across the scene."""

from __future__ import annotations

from typing import Any

from radcons.io import Pair

__all__ = ["bands_text", "geometry_text", "rectification_text", "noise_text", "light_text"]


def bands_text(pair: Pair) -> str:
    """How the grey band of each image was made from its file (:attr:`Raster.bands`)."""
    reference, target = pair.reference.bands, pair.target.bands
    if reference == target:
        return f"Bands: {reference} (both images)"
    return f"Bands: reference {reference}; target {target}"


def geometry_text(pair: Pair) -> str:
    """Whether the pair is taken as epipolar-rectified, and why.

    The reason :func:`radcons.geometry.settle_geometry` noted, else the pair's own word
    (its folder's ``rectified`` key, ``--rectified`` / ``--unrectified``, or the demo),
    and what :func:`radcons.geometry.level_rows` did to its target's rows.
    """
    note = pair.metadata.get("geometry") or f"{'rectified' if pair.rectified else 'unrectified'} (as given)"
    rows = pair.metadata.get("rows")
    return f"{note}; {rows}" if rows else str(note)


def rectification_text(rectification: Any, factor: int) -> str:
    """The epipolar resampling's residual vertical parallax, matches and orientation, in words.

    Parameters
    ----------
    rectification : Rectification or None
        ``Run.rectification`` (None: the pair was rectified, nothing was resampled).
    factor : int
        Downsampling of the pair the run worked on (its pixels are ``factor`` of the
        pair's).
    """
    if rectification is None:
        return ""
    scale = f" (px of the preview, 1:{factor})" if factor > 1 else ""
    lines = [
        f"**Epipolar resampling** ({getattr(rectification, 'method', 'affine')}): residual vertical parallax "
        f"median {rectification.residual_parallax_median:.2f} px, p90 {rectification.residual_parallax_p90:.2f} px{scale}",
    ]
    inliers, matches = getattr(rectification, "n_inliers", None), getattr(rectification, "n_matches", None)
    if inliers is not None and matches is not None:
        lines.append(f"{inliers} of {matches} SIFT matches kept")
    low, high = rectification.disparity_range
    lines.append(f"disparity range {low:.0f} .. {high:.0f} px")
    orientation = getattr(rectification, "orientation", "")
    if orientation:
        lines.append(f"which way up: {orientation}")
    reason = getattr(rectification, "reason", "")
    if reason:
        lines.append(f"_{reason}_")
    return "  \n".join(lines)


def noise_text(run: Any) -> str:
    """The noise notice of a run's final images as the output files hold them
    (:func:`radcons.summary.run_noise_notice`, :func:`radcons.summary.written_noise_ratio`),
    empty when their noise ratio is at most 1.5."""
    from radcons.summary import run_noise_notice, written_noise_ratio

    return run_noise_notice(run, written_noise_ratio(run)) or ""


def light_text(run: Any) -> str:
    """Whether the run's refine stage corrected light varying across the scene
    (:func:`radcons.stages.refine.run.background_mapping`), with the spread it measured
    against ``local_min_light``; empty without the local background."""
    refine = run.results.get("refine")
    done = refine.info if refine is not None else {}
    if "light_spread" not in done:
        return ""
    moved = f"{done['light_spread']:.3f} of the reference's range"
    bound = f"`local_min_light` {run.params.refine.local_min_light:g}"
    if done["light_applied"]:
        return f"Light across the scene: corrected per tile (it moved the target by {moved}, at least {bound})."
    return (
        f"Light across the scene: not corrected (the tile correction would move the target by {moved}, "
        f"below {bound}: the tiles differ by content, not light)."
    )
