"""Simulated date and sensor differences for the target of a real stereo pair.

No public stereo pair with ground truth was taken at two dates by two sensors, so the
evaluation degrades the target of a real pair with ground truth (Middlebury Cones,
Motorcycle) the way a second date and a second sensor would: a different illumination
(gamma, gain, offset), a local overexposure that saturates (the paper's Object 1), a
different sensor point spread (blur) and a different noise level.

:class:`Degradation` / :func:`degrade` apply one fixed degradation. The randomised
benchmark instead draws a :class:`Difference` per seed (:func:`sample_difference`) from the
ranges of :data:`RANGES` and applies it to a pair (:func:`simulate_pair`), composing the
single differences of :mod:`radcons.evaluate.differences`. Seeds are split once, here,
into a tuning set and a held-out set (:func:`split_of`, :func:`split_seeds`): defaults are
chosen on the tuning seeds only and the held-out seeds are what the report headlines.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy import ndimage

from radcons.errors import InputError, ParamsError
from radcons.evaluate import differences as diff
from radcons.io import Pair, Raster
from radcons.pipeline import to_output_dtype

__all__ = [
    "Degradation",
    "degrade",
    "KINDS",
    "RANGES",
    "SPLITS",
    "Difference",
    "sample_difference",
    "simulate_pair",
    "split_of",
    "split_seeds",
]


@dataclass(frozen=True)
class Degradation:
    """What :func:`degrade` does to an image, applied in the order of the attributes.

    With ``[low, high]`` the image's value range (finite minimum and maximum) and
    ``u = (v - low) / (high - low)``:

    Attributes
    ----------
    gamma : float
        Illumination nonlinearity: ``v <- low + (high - low) * u ** gamma``.
    gain, offset : float
        Linear radiometric change: ``v <- gain * v + offset``.
    saturate_box : (int, int, int, int) or None
        Rectangle ``(x0, y0, x1, y1)`` (end exclusive) pushed above the range: its values
        are multiplied by ``saturate_factor`` and then clipped at ``high`` with the rest.
    saturate_label : int or None
        Same, for the pixels of this object id of the ``labels`` given to :func:`degrade`.
    saturate_factor : float
        Brightening factor of the saturated region (> 1).
    blur_sigma : float
        Gaussian point spread of the other sensor, in pixels (0 = none). NaN pixels are
        left out of the average (normalised convolution).
    noise_sigma : float
        Standard deviation of additive white Gaussian noise, in the image's units.
    seed : int
        Seed of the noise generator.

    Finally every value is clipped to ``[low, high]``, as a sensor saturates.
    """

    gamma: float = 1.0
    gain: float = 1.0
    offset: float = 0.0
    saturate_box: tuple[int, int, int, int] | None = None
    saturate_label: int | None = None
    saturate_factor: float = 1.5
    blur_sigma: float = 0.0
    noise_sigma: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.gamma > 0:
            raise ParamsError(f"gamma must be positive, got {self.gamma}")
        if not self.gain > 0:
            raise ParamsError(f"gain must be positive, got {self.gain}")
        if not self.saturate_factor > 0:
            raise ParamsError(f"saturate_factor must be positive, got {self.saturate_factor}")
        if self.blur_sigma < 0 or self.noise_sigma < 0:
            raise ParamsError("blur_sigma and noise_sigma must be >= 0")
        if self.saturate_box is not None:
            x0, y0, x1, y1 = self.saturate_box
            if not (0 <= x0 < x1 and 0 <= y0 < y1):
                raise ParamsError(
                    f"saturate_box must be (x0, y0, x1, y1) with x0 < x1, y0 < y1, got {self.saturate_box}"
                )


def degrade(
    image: np.ndarray, degradation: Degradation, labels: np.ndarray | None = None
) -> np.ndarray:
    """Apply a simulated date / sensor difference to an image.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.
    degradation : Degradation
        What to apply (see its attributes for the formulas and their order).
    labels : ndarray of int, optional
        Object labels of ``image``, needed with ``degradation.saturate_label``.

    Returns
    -------
    ndarray of float32
        The degraded image on the input's value range, NaN kept.

    Raises
    ------
    InputError
        Not 2-D, constant, labels missing or of another shape, or the saturated region
        empty.
    """
    image = np.asarray(image, dtype=np.float64)
    if image.ndim != 2:
        raise InputError(f"degrade needs a 2-D image, got shape {image.shape}")
    valid = np.isfinite(image)
    normalised, low, high = _normalised(image)
    out = low + (high - low) * np.clip(normalised, 0.0, 1.0) ** degradation.gamma
    out = degradation.gain * out + degradation.offset
    region = _saturated_region(image.shape, degradation, labels)
    if region is not None:
        out[region] *= degradation.saturate_factor
    if degradation.blur_sigma > 0:
        out = _blur_valid(out, valid, degradation.blur_sigma)
    if degradation.noise_sigma > 0:
        rng = np.random.default_rng(degradation.seed)
        out = out + rng.normal(0.0, degradation.noise_sigma, size=out.shape)
    out = np.clip(out, low, high)
    out[~valid] = np.nan
    return out.astype(np.float32)


def _saturated_region(
    shape: tuple[int, int], degradation: Degradation, labels: np.ndarray | None
) -> np.ndarray | None:
    """Boolean mask of the region pushed above the range, or None."""
    if degradation.saturate_box is None and degradation.saturate_label is None:
        return None
    region = np.zeros(shape, bool)
    if degradation.saturate_box is not None:
        x0, y0, x1, y1 = degradation.saturate_box
        region[y0:y1, x0:x1] = True
    if degradation.saturate_label is not None:
        if labels is None or labels.shape != shape:
            raise InputError("saturate_label needs the image's object labels (same shape)")
        region |= labels == degradation.saturate_label
    if not region.any():
        raise InputError("the saturated region lies outside the image or names no object")
    return region


def _blur_valid(image: np.ndarray, valid: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur that averages valid pixels only (normalised convolution)."""
    weight = ndimage.gaussian_filter(valid.astype(np.float64), sigma, mode="nearest")
    blurred = ndimage.gaussian_filter(np.where(valid, image, 0.0), sigma, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(weight > 0, blurred / weight, np.nan)


#: Difference kinds, one per seed in turn (``KINDS[seed % len(KINDS)]``). Every seed also
#: draws a tone curve (a second date always changes it); "tone" has nothing else, "mixed"
#: adds each other kind with probability 1/2.
KINDS: tuple[str, ...] = (
    "tone", "bit_depth", "blur", "noise", "light", "shadows", "clipping", "compression", "mixed",
)
#: The ranges the parameters are drawn from (uniform; gamma log-uniform). Image values are
#: normalised to ``u`` in [0, 1] by each image's own finite range first, so sigmas,
#: offsets and levels are fractions of that range (0.01 is 2.55 grey levels of 8 bits).
RANGES: dict[str, tuple[float, float]] = {
    "gamma": (0.5, 2.0),
    "s_curve": (-0.6, 0.6),
    "gain": (0.7, 1.3),
    "offset": (-0.1, 0.1),
    "fill": (0.25, 1.0),  # share of a bits-bit range the signal fills
    "blur_sigma": (0.5, 2.0),  # px, on the reference or the target
    "noise_sigma": (0.01, 0.04),  # on the reference or the target
    "noise_signal": (0.0, 0.002),  # signal-dependent variance per unit of u
    "gradient": (0.1, 0.4),
    "vignetting": (0.0, 0.4),
    "haze": (0.0, 0.4),
    "haze_level": (0.6, 1.0),
    "shadow_count": (2, 8),
    "shadow_area": (0.05, 0.2),
    "shadow_darkening": (0.3, 0.7),
    "clip_objects": (1, 3),
    "clip_factor": (1.3, 2.0),
    "jpeg_quality": (10, 50),
}
#: Bit depths a target may be recorded with.
BIT_DEPTHS: tuple[int, ...] = (8, 11, 12)
#: The two seed sets.
SPLITS: tuple[str, ...] = ("tuning", "held-out")


@dataclass(frozen=True)
class Difference:
    """One sampled date / sensor difference; :func:`simulate_pair` applies it.

    On the target, with ``u`` its values normalised by its own finite range, in this
    order: spatially varying light (:func:`~radcons.evaluate.differences.light_field`:
    ``gradient`` along ``angle``, ``vignetting``, ``haze`` towards ``haze_level``), cast
    shadows (``shadow_count`` ellipses over ``shadow_area`` darkened by
    ``shadow_darkening``), the tone curve (``gamma``, ``s_curve``, ``gain``, ``offset``),
    over-exposed objects (``clip_objects`` target objects times ``clip_factor``), clipping
    to [0, 1]; then on the image named by ``blur_on`` a Gaussian blur of ``blur_sigma`` px
    and on the image named by ``noise_on`` noise of variance ``noise_sigma**2 +
    noise_signal * u``; then the target is recorded: ``bits`` bits over ``fill`` of the
    range (integer counts), or a JPEG of ``jpeg_quality``, or (neither) back on its own
    value range. Both images are then stored as a sensor product stores them: whole levels
    of the source's integer dtype (the ``bits`` target: 8-bit or 16-bit), float where the
    source is float. A field at its default does nothing.
    """

    kind: str
    seed: int
    gamma: float = 1.0
    s_curve: float = 0.0
    gain: float = 1.0
    offset: float = 0.0
    bits: int | None = None
    fill: float = 1.0
    blur_sigma: float = 0.0
    blur_on: str = "target"
    noise_sigma: float = 0.0
    noise_signal: float = 0.0
    noise_on: str = "target"
    gradient: float = 0.0
    angle: float = 0.0
    vignetting: float = 0.0
    haze: float = 0.0
    haze_level: float = 0.8
    shadow_count: int = 0
    shadow_area: float = 0.1
    shadow_darkening: float = 0.5
    clip_objects: int = 0
    clip_factor: float = 1.5
    jpeg_quality: int | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ParamsError(f"unknown difference kind {self.kind!r} (known: {', '.join(KINDS)})")
        for side in (self.blur_on, self.noise_on):
            if side not in ("reference", "target"):
                raise ParamsError(f"blur_on / noise_on must be 'reference' or 'target', got {side!r}")
        if self.bits is not None and self.jpeg_quality is not None:
            raise ParamsError("a target is recorded either with a bit depth or as a JPEG, not both")

    @property
    def split(self) -> str:
        """The seed set this difference belongs to."""
        return split_of(self.seed)


def split_of(seed: int) -> str:
    """``"tuning"`` or ``"held-out"``: seeds alternate by blocks of ``len(KINDS)``.

    Seeds 0-8 are tuning, 9-17 held-out, 18-26 tuning, ...; each block holds every kind once.
    """
    if seed < 0:
        raise ParamsError(f"seeds are >= 0, got {seed}")
    return SPLITS[(seed // len(KINDS)) % 2]


def split_seeds(split: str, blocks: int = 1) -> list[int]:
    """The first ``blocks * len(KINDS)`` seeds of a split, in order."""
    if split not in SPLITS:
        raise ParamsError(f"unknown split {split!r} (known: {', '.join(SPLITS)})")
    first = SPLITS.index(split)
    return [2 * block * len(KINDS) + first * len(KINDS) + i for block in range(blocks) for i in range(len(KINDS))]


def sample_difference(seed: int) -> Difference:
    """Draw the difference of one seed: its kind is ``KINDS[seed % len(KINDS)]``."""
    split_of(seed)  # validates the seed
    kind = KINDS[seed % len(KINDS)]
    rng = np.random.default_rng([seed, 20])

    def draw(name: str) -> float:
        low, high = RANGES[name]
        return float(rng.uniform(low, high))

    def draw_int(name: str) -> int:
        low, high = RANGES[name]
        return int(rng.integers(low, high + 1))

    values: dict = {
        "gamma": float(math.exp(rng.uniform(*np.log(RANGES["gamma"])))),
        "s_curve": draw("s_curve"),
        "gain": draw("gain"),
        "offset": draw("offset"),
    }
    chosen = [k for k in KINDS[1:-1] if rng.random() < 0.5] if kind == "mixed" else [kind]
    if "compression" in chosen and "bit_depth" in chosen:
        chosen.remove("bit_depth")
    side = ("reference", "target")
    for name in chosen:
        if name == "bit_depth":
            values.update(bits=int(rng.choice(BIT_DEPTHS)), fill=draw("fill"))
        elif name == "blur":
            values.update(blur_sigma=draw("blur_sigma"), blur_on=side[int(rng.integers(2))])
        elif name == "noise":
            values.update(noise_sigma=draw("noise_sigma"), noise_signal=draw("noise_signal"), noise_on=side[int(rng.integers(2))])
        elif name == "light":
            values.update(
                gradient=draw("gradient"), angle=float(rng.uniform(0, 2 * math.pi)), vignetting=draw("vignetting"),
                haze=draw("haze"), haze_level=draw("haze_level"),
            )
        elif name == "shadows":
            values.update(
                shadow_count=draw_int("shadow_count"), shadow_area=draw("shadow_area"),
                shadow_darkening=draw("shadow_darkening"),
            )
        elif name == "clipping":
            values.update(clip_objects=draw_int("clip_objects"), clip_factor=draw("clip_factor"))
        elif name == "compression":
            values.update(jpeg_quality=draw_int("jpeg_quality"))
    return Difference(kind=kind, seed=seed, **values)


def _normalised(image: np.ndarray) -> tuple[np.ndarray, float, float]:
    image = np.asarray(image, dtype=np.float64)
    valid = np.isfinite(image)
    if not valid.any():
        raise InputError("the image has no valid pixel")
    low, high = float(image[valid].min()), float(image[valid].max())
    if not high > low:
        raise InputError("the image is constant")
    return (image - low) / (high - low), low, high


def _clip_region(pair: Pair, difference: Difference, rng: np.random.Generator) -> np.ndarray:
    """The target pixels over-exposed: ``clip_objects`` of the target's objects (else ellipses)."""
    labels = pair.target_objects
    ids = np.unique(labels[labels > 0]) if labels is not None else np.array([], int)
    if ids.size == 0:
        return diff.shadow_mask(pair.shape, difference.clip_objects, 0.03 * difference.clip_objects, rng)
    chosen = rng.choice(ids, size=min(difference.clip_objects, ids.size), replace=False)
    return np.isin(labels, chosen)


def _recorded(image: np.ndarray, dtype: np.dtype) -> Raster:
    """``image`` stored as a sensor product stores it: whole levels of an integer ``dtype``
    (rounded, clipped to its range), so that the method and the baselines start from the
    grey levels, and the ties between neighbours, that a delivered file holds. A float
    ``dtype``, or an image with invalid pixels (an integer has no NaN), stays float32.
    The rounding is the writer's (:func:`radcons.pipeline.to_output_dtype`)."""
    if np.dtype(dtype).kind == "f" or not np.isfinite(image).all():
        return Raster(np.asarray(image, np.float32))
    return Raster(to_output_dtype(image, dtype, None))


def simulate_pair(pair: Pair, difference: Difference) -> Pair:
    """The pair with ``difference`` applied (see :class:`Difference` for the order).

    Parameters
    ----------
    pair : Pair
        A rectified pair; its ground truth and object labels are kept as they are.
    difference : Difference

    Returns
    -------
    Pair
        Images in the dtypes :class:`Difference` records them in (the reference as given
        unless blurred or noised), NaN kept in float32; named ``"{name} {kind} s{seed}"``.
    """
    reference = pair.reference.as_float32().astype(np.float64)
    u, low, high = _normalised(pair.target.as_float32())
    rng = np.random.default_rng([difference.seed, 21])
    d = difference
    if d.gradient or d.vignetting or d.haze:
        u = diff.light_field(u, d.gradient, d.angle, d.vignetting, d.haze, d.haze_level)
    if d.shadow_count:
        u = diff.cast_shadows(u, diff.shadow_mask(u.shape, d.shadow_count, d.shadow_area, rng), d.shadow_darkening)
    u = diff.tone_curve(u, d.gamma, d.s_curve, d.gain, d.offset)
    if d.clip_objects:
        u = diff.clip_objects(u, _clip_region(pair, d, rng), d.clip_factor)
    u = np.clip(u, 0.0, 1.0)
    if d.blur_sigma:
        if d.blur_on == "target":
            u = diff.gaussian_blur(u, d.blur_sigma)
        else:
            r, r_low, r_high = _normalised(reference)
            reference = r_low + (r_high - r_low) * diff.gaussian_blur(r, d.blur_sigma)
    if d.noise_sigma or d.noise_signal:
        if d.noise_on == "target":
            u = np.clip(diff.add_noise(u, d.noise_sigma, d.noise_signal, rng), 0.0, 1.0)
        else:
            r, r_low, r_high = _normalised(reference)
            r = np.clip(diff.add_noise(r, d.noise_sigma, d.noise_signal, rng), 0.0, 1.0)
            reference = r_low + (r_high - r_low) * r
    if d.bits is not None:
        target = diff.quantise(u, d.bits, d.fill)
    elif d.jpeg_quality is not None:
        target = low + (high - low) * diff.jpeg_roundtrip(u, d.jpeg_quality)
    else:
        target = low + (high - low) * u
    reference[~np.isfinite(pair.reference.as_float32())] = np.nan
    target_dtype = pair.target.data.dtype if d.bits is None else np.dtype(np.uint8 if d.bits <= 8 else np.uint16)
    return replace(
        pair,
        reference=_recorded(reference, pair.reference.data.dtype),
        target=_recorded(target, target_dtype),
        name=f"{pair.name} {d.kind} s{d.seed}",
        metadata={**pair.metadata, "difference": asdict(d)},
    )
