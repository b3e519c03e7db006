"""Evaluation of a bag played through the pipeline: ``playback`` (play the bag through the
launch and record the outputs), ``analysis`` (the figures of a recorded run against the
bag and its ground truth), ``metrics`` (scan quality against the ideal scan), ``mapping``
(occupancy grids at known poses), ``slam`` (MRPT SLAM and localization), ``report``
(Markdown, plots, JSON) and ``evaluate`` (all of it: the evaluate_bag tool).
Imports ``ros``, ``simulation`` and ``config_check`` of the toolbox, never ``experiments``."""
