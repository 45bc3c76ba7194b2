"""Roofs the height method cut in parts, joined again.

The snapping of :mod:`radcons.stages.objects.regions` places object boundaries on the
reference's strongest edges, and some of those lie inside a roof:

- :mod:`~radcons.stages.objects.joins.halves`: the two planes of a gabled roof, split at
  its ridge (``join_roof_halves``);
- :mod:`~radcons.stages.objects.joins.mirror`: a gabled roof found by one plane only, grown
  by the other plane across its ridge (``complete_gables``);
- :mod:`~radcons.stages.objects.joins.wings`: rectangular parts of one flat roof that touch
  across the smaller's width (``join_wings``).
"""
