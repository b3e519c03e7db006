"""Experiments and benchmarks on top of the evaluation: ``cpu`` (CPU against depth points),
``transport`` (one nodelet manager against standalone nodes), ``camera_path`` (CPU per depth
frame of a camera's path), ``soak`` (long run at 10x the sensor rates) and ``fuzz_inputs``
(the node fuzz's malformed messages). The top layer: nothing of the toolbox imports it."""
