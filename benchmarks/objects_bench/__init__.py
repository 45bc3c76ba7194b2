"""The sections of ``benchmarks/bench_objects.py``, one module per job.

* :mod:`.common`: the measures against the demo generator's buildings and the US3D lidar,
  and the demo pairs' height objects, found once a run;
* :mod:`.demo`: the ``demo``, ``misses`` and ``trees`` sections;
* :mod:`.timing`: the ``timing`` section;
* :mod:`.real`: the ``real`` section;
* :mod:`.heldout`: the ``heldout`` section, objects as ``radcons process`` finds them on
  pairs no value was chosen on, by ground.
* :mod:`.ablation`: the ``ablation`` section, what each rule of the height method buys,
  switched off in turn.

``benchmarks/bench_objects.py`` is the command. The modules import ``radcons`` and
``demo_data_gen`` as top-level modules: Python puts the script's own folder
(``benchmarks/``, which holds this package) first on the import path.
"""
