"""Searches for the roofs the height method's elevated regions missed.

Each looks where the regions of :mod:`radcons.stages.objects.regions` fail, and adds the
roofs it verifies as new objects with their own D̄m:

- :mod:`~radcons.stages.objects.searches.clipped`: roofs clipped whole at full scale in
  one image (glare), where census sees nothing; placed where the other image's edges
  follow their outline (``find_clipped``);
- :mod:`~radcons.stages.objects.searches.missed`: buildings too small for the census grid,
  as segments of the reference matched on their own (``find_missed``);
- :mod:`~radcons.stages.objects.searches.parts`: roofs inside a region a rule removed
  whole, as fine segments verified and joined (``find_in_removed``).

The two census searches judge their candidates by
:class:`radcons.stages.objects.census_check.CensusCheck`.
"""
