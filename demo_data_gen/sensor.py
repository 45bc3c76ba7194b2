"""From radiance to digital numbers: the date's radiometry, the sensor's optics and noise.

``acquire`` applies, in order: the date's linear radiometric change ``gain * L + offset``
(atmosphere, exposure), the sensor's point spread (a Gaussian of ``blur_sigma`` pixels,
standing for its MTF), the date's tone curve ``v ** gamma``, white Gaussian read noise of
``noise_sigma`` digital numbers, and quantisation to the sensor's bit depth with
saturation at full scale (``v >= 1`` reads full scale whatever the noise). Noise is added
after the tone curve, so its level in digital numbers belongs to the sensor alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Sensor", "Radiometry", "acquire"]


@dataclass(frozen=True)
class Sensor:
    """An imaging sensor.

    Attributes
    ----------
    name : str
    bit_depth : int
        Digital numbers run 0 .. 2**bit_depth - 1 (stored as uint16).
    noise_sigma : float
        Standard deviation of the read noise, in digital numbers.
    blur_sigma : float
        Standard deviation of the Gaussian point spread function, in pixels.
    """

    name: str
    bit_depth: int
    noise_sigma: float
    blur_sigma: float

    @property
    def full_scale(self) -> int:
        """Largest digital number."""
        return 2**self.bit_depth - 1


@dataclass(frozen=True)
class Radiometry:
    """Radiometric transfer of one acquisition date: ``(gain * L + offset) ** gamma``."""

    gain: float = 1.0
    offset: float = 0.0
    gamma: float = 1.0


def acquire(radiance: np.ndarray, radiometry: Radiometry, sensor: Sensor, rng: np.random.Generator) -> np.ndarray:
    """Image ``radiance`` (1 = full scale) with a sensor on a date.

    Parameters
    ----------
    radiance : ndarray, float32
    radiometry : Radiometry
    sensor : Sensor
    rng : numpy.random.Generator
        Draws the noise.

    Returns
    -------
    ndarray, uint16
        Digital numbers in ``0 .. sensor.full_scale``.
    """
    value = (radiometry.gain * radiance + radiometry.offset).astype(np.float32)
    if sensor.blur_sigma > 0:
        value = cv2.GaussianBlur(value, (0, 0), sensor.blur_sigma, borderType=cv2.BORDER_REFLECT)
    value = np.maximum(value, 0.0) ** radiometry.gamma
    noise = rng.standard_normal(value.shape, dtype=np.float32)
    dn = value * sensor.full_scale + sensor.noise_sigma * noise
    return np.clip(np.rint(dn), 0, sensor.full_scale).astype(np.uint16)
