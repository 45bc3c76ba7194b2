"""Report sections of the real pairs: the pairs with real ground truth and the Pleiades pair,
each with the paper's per-object Tables 1 and 2."""

from __future__ import annotations

import numpy as np

from .common import COMPARED, Entry
from .tables import bold_best, fmt, md_table, metric, object_sizes


def per_object_tables(entry: Entry) -> str:
    """Tables 1 and 2 of the paper for one pair, plus noise ratio and times.

    Parameters
    ----------
    entry : Entry
        The evaluated pair.

    Returns
    -------
    str
        Markdown, starting with an empty line.
    """
    comparison = entry.comparison
    present = {m.name for m in comparison.methods}
    names = [n for n in ("undegraded", *COMPARED) if n in present]
    sizes = object_sizes(entry.pair)
    ids = [ref_id for ref_id, _ in comparison.object_pairs]
    header = ["object (px)", *names]
    lines = ["", "Object similarity C (eq 20), as the paper's Table 1:", ""]
    rows = [[f"{i} ({sizes.get(i, 0)})", *bold_best([comparison.method(n).similarity.get(i, np.nan) for n in names])] for i in ids]
    rows.append(["**mean**", *bold_best([comparison.method(n).mean_similarity for n in names])])
    lines.append(md_table(header, rows))
    lines += ["", "Correct-matching rate (|d - d_gt| < 1 px), as the paper's Table 2:", ""]
    rows = [[f"{i} ({sizes.get(i, 0)})", *bold_best([comparison.method(n).object_rates.get(i, np.nan) for n in names])] for i in ids]
    rows.append(["**mean (objects)**", *bold_best([comparison.method(n).mean_object_rate for n in names])])
    rows.append(["**all pixels**", *bold_best([metric(comparison.method(n), "rate") for n in names])])
    lines.append(md_table(header, rows))
    lines += unmatchable_note(entry)
    lines += ["", "Noise ratio (larger over smaller noise sigma of the two images; 1 = same noise) and "
              "normalisation time:", ""]
    rows = [
        ["noise ratio", *[fmt(comparison.method(n).noise_ratio, 2) for n in names]],
        ["normalisation s", *[fmt(comparison.method(n).seconds.get("normalisation"), 2) for n in names]],
    ]
    lines.append(md_table(["", *names], rows))
    return "\n".join(lines)


def unmatchable_note(entry: Entry) -> list[str]:
    """Objects that even the undegraded pair does not match (< 5 %), and why when it is the
    matcher's left border (SGBM leaves the first columns without a match).

    Parameters
    ----------
    entry : Entry
        The evaluated pair.

    Returns
    -------
    list of str
        Lines of the note; empty without an ``undegraded`` method or such objects.
    """
    comparison = entry.comparison
    names = [m.name for m in comparison.methods]
    if "undegraded" not in names:
        return []
    clean = comparison.method("undegraded")
    bad = [i for i, _ in comparison.object_pairs if clean.object_rates.get(i, 1.0) < 0.05]
    if not bad:
        return []
    matched_cols = np.nonzero(np.isfinite(clean.disparity).any(axis=0))[0]
    border = int(matched_cols[0]) if matched_cols.size else entry.pair.shape[1]
    labels = entry.pair.reference_objects
    parts = []
    for i in bad:
        share = float(np.mean(np.nonzero(labels == i)[1] < border))
        parts.append(f"{i} ({100 * share:.0f} % of it in that border)")
    return [
        "",
        f"Objects that not even the undegraded pair matches (rate < 0.05): {', '.join(parts)}. The matcher "
        f"leaves the first {border} columns without a match; these objects count as failed for every "
        "method alike and pull every mean down the same way.",
    ]


def section_truth_pairs(entries: list[Entry], skipped: list[str]) -> str:
    """The real pairs with real ground truth: how each was built, and its per-object tables.

    Parameters
    ----------
    entries : list of Entry
        The evaluated pairs.
    skipped : list of str
        A note per pair that was not found.

    Returns
    -------
    str
        The markdown section.
    """
    lines = ["## Real stereo pairs with real ground truth, simulated date / sensor difference", ""]
    lines.append(
        "The reference image is the real left image; the target is the real right image degraded as in "
        "\"What was run\". \"undegraded\" is the real pair as it is, measured the same way (not a method: "
        "what the normalisation should get back to). Objects: connected 4 px disparity layers of the "
        "ground truth (at least 300 px, the 12 largest, numbered by decreasing area), carried into the "
        "target along the ground truth (`radcons.evaluate.truth_pairs`)."
    )
    for note in skipped:
        lines += ["", f"*{note}*"]
    for entry in entries:
        clipped = entry.extra.get("saturated_share_clipped", float("nan"))
        lines += [
            "",
            f"### {entry.title}",
            "",
            f"Built from {entry.built}; {entry.pair.shape[1]} x {entry.pair.shape[0]} px, "
            f"{len(entry.comparison.object_pairs)} objects; disparity search "
            f"{entry.comparison.disparity_range[0]:.1f} .. {entry.comparison.disparity_range[1]:.1f} px. "
            f"Object {entry.extra.get('saturated_object')} is the saturated one "
            f"({fmt(100 * clipped, 0)} % of its target pixels clipped).",
        ]
        lines.append(per_object_tables(entry))
    return "\n".join(lines)


def section_pleiades(entry: Entry | None, note: str | None) -> str:
    """The Pleiades pair: how its reference disparity and degradation were made, and its tables.

    Parameters
    ----------
    entry : Entry or None
        The evaluated pair, None when it was skipped.
    note : str or None
        Why it was skipped.

    Returns
    -------
    str
        The markdown section.
    """
    lines = ["## Real Pleiades pair (La Reunion), no ground truth", ""]
    if entry is None:
        lines.append(f"*{note}*")
        return "\n".join(lines)
    info = entry.extra
    degradation = info["degradation"]
    clipped = info.get("saturated_share_clipped", float("nan"))
    lines.append(
        f"Built from {entry.built}. No ground truth exists: the reference disparity is the SGBM disparity "
        "of the clean pair (same matcher), computed both ways (the target's by matching the mirrored "
        "images) and kept where the two agree within 1 px: "
        f"{100 * info['left_valid_share']:.0f} % of the pixels had a match, {100 * info['kept_share']:.0f} % "
        f"passed the check (search range {info['search_range'][0]:.1f} .. {info['search_range'][1]:.1f} px, "
        "from the SIFT matches). Objects: connected 4 px layers of that disparity (at least 300 px, the 12 "
        "largest), carried into the target along it; they are terrain patches, not buildings. "
        "The target then gets the simulated difference, with the offset and the noise (given for 0..255) "
        f"scaled to the target's 1-99 % span ({info['percentile_span'][0]:.0f} .. {info['percentile_span'][1]:.0f}): "
        f"offset {degradation['offset']:.1f}, noise sigma {degradation['noise_sigma']:.2f}. Object "
        f"{info['saturated_object']} is brightened; {fmt(100 * clipped, 0)} % of its pixels reach the "
        "clip level (a few bright outliers set the image's maximum far above its content). "
        "The \"undegraded\" column matches the clean pair against a reference made from that same pair, so "
        "it is high by construction; the methods are measured by how close they bring the degraded pair's "
        "matching to the clean pair's."
    )
    lines.append(per_object_tables(entry))
    return "\n".join(lines)
