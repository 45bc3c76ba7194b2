"""The results report of ``benchmarks/make_results.py``, one module per job.

* :mod:`.common`: the methods, metrics and colours of the report, its settings and one
  evaluated pair (:class:`~.common.Entry`);
* :mod:`.run`: the pairs (synthetic, real with ground truth, Pleiades) and the evaluation of
  every method on them;
* :mod:`.tables`: markdown tables and the numbers they show (metrics, seed means, winners);
* :mod:`.synthetic`, :mod:`.real`, :mod:`.summary`: the sections of the synthetic pairs, of
  the real pairs, and of all pairs together;
* :mod:`.figures`: the bar charts and dense-matching error maps;
* :mod:`.page`: the run of the whole report, ``results.md`` and ``results.json``.

``benchmarks/make_results.py`` is the command. The modules import ``radcons``,
``demo_data_gen`` and ``bench_baselines`` as top-level modules: the command puts the
checkout first on the import path, and Python puts the script's own folder (``benchmarks/``,
which holds this package and ``bench_baselines``) there.
"""
