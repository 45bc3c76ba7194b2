"""Cars of a city quarter: parked or driving in the road lanes, and in parking bays."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from demo_data_gen.scene import Car, Lot, Rect
from demo_data_gen.streets import bays

__all__ = ["road_cars", "parking_cars"]

#: Body reflectances a car is drawn from (black to white).
_CAR_ALBEDOS = np.array([0.06, 0.1, 0.2, 0.35, 0.55, 0.7, 0.8])


def road_cars(rng: np.random.Generator, roads: Sequence[Rect], keep: tuple[Car, ...]) -> list[Car]:
    """Place cars parked or driving in both lanes of each road, clear of ``keep``.

    Parameters
    ----------
    rng : numpy.random.Generator
        The random generator of the scene or of the date being drawn.
    roads : sequence of Rect
        The carriageways.
    keep : tuple of Car
        Cars already there; new ones keep 0.6 m away from them.

    Returns
    -------
    list of Car
        The new cars (``keep`` not included).
    """
    cars: list[Car] = []
    for road in roads:
        along_x = road.width > road.height
        lo, hi = (road.x0, road.x1) if along_x else (road.y0, road.y1)
        c0, c1 = (road.y0, road.y1) if along_x else (road.x0, road.x1)
        for lane in (c0 + 0.25 * (c1 - c0), c0 + 0.75 * (c1 - c0)):
            s = lo + rng.exponential(40.0)
            while s < hi:
                length, width = rng.uniform(4.0, 5.0), rng.uniform(1.7, 1.95)
                t = lane + rng.normal(0.0, 0.3) - 0.5 * width
                rect = Rect(s, t, s + length, t + width) if along_x else Rect(t, s, t + width, s + length)
                if not any(rect.intersects(c.rect, 0.6) for c in keep):
                    cars.append(Car(rect, float(rng.choice(_CAR_ALBEDOS)), along_x))
                s += length + 1.5 + rng.exponential(40.0)
    return cars


def parking_cars(rng: np.random.Generator, lots: Sequence[Lot]) -> list[Car]:
    """Park cars in about 60 % of the bays of the parking lots.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    lots : sequence of Lot
        The lots of the quarter; only ``"parking"`` lots get cars.

    Returns
    -------
    list of Car
    """
    cars: list[Car] = []
    for lot in lots:
        if lot.use != "parking":
            continue
        for bay in bays(lot):
            if rng.random() < 0.6:
                w, length = rng.uniform(1.7, 1.95), rng.uniform(4.0, 4.7)
                cx = bay.x0 + 1.3 - 0.5 * w
                cars.append(Car(Rect(cx, bay.y0 + 0.2, cx + w, bay.y0 + 0.2 + length), float(rng.choice(_CAR_ALBEDOS)), False))
    return cars
