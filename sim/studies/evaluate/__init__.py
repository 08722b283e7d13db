"""``shipradar evaluate``: score a tracker under test on seeded runs (issue 26).

One module per role:

- :mod:`~shipradar.sim.studies.evaluate.runner`: one seeded run, the simulator publishing
  and recording, the tracker in its own process (or a Python object in process), its
  ``tracks`` collected with their receive times; everything written to a run directory;
- :mod:`~shipradar.sim.studies.evaluate.data`: a run directory read back (truth, scan
  times, radar positions, the tracker's valid and malformed ``tracks`` messages);
- :mod:`~shipradar.sim.studies.evaluate.metrics`: which truth counts, time alignment,
  GOSPA and SIAP through Stone Soup's metric generators, and the per-target figures no
  library has (first track, breaks, identity swaps, false tracks, latency);
- :mod:`~shipradar.sim.studies.evaluate.stats`: means and 95 % intervals over runs, paired
  differences for a comparison;
- :mod:`~shipradar.sim.studies.evaluate.study`: the runs of a study on Dask, rescoring,
  comparison;
- :mod:`~shipradar.sim.studies.evaluate.report`: ``index.html`` and its SVG figures
  (every number through :func:`~shipradar.sim.studies.evaluate.display.format_value`);
- :mod:`~shipradar.sim.studies.evaluate.cli`: the ``shipradar evaluate`` sub-command.
"""
