"""Synthetic urban stereo pairs with ground truth (disparity, building labels, changes).

>>> from demo_data_gen import generate
>>> pair = generate(size=256, seed=1, scenario="mixed")
"""

from demo_data_gen.pairs import SCENARIOS, generate

__all__ = ["SCENARIOS", "generate"]
