"""Evaluation of a bag played through the pipeline: ``evaluate`` (the evaluate_bag tool),
``metrics`` (scan quality against the ideal scan), ``mapping`` (occupancy grids at known
poses), ``slam`` (MRPT SLAM and localization) and ``report`` (Markdown and plots).
Imports ``ros``, ``simulation`` and ``config_check`` of the toolbox, never ``experiments``."""
