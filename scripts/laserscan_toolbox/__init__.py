"""Tools of the unified laser-scan toolbox (ROS 1), one importable module.

Sub-modules (import them explicitly; none is imported here so that a tool only
pays for what it uses):

- ``world``     shop-floor world made of primitives (boxes, vertical cylinders,
                floor holes, walking people), serialisable to a dict/YAML.
- ``raycast``   vectorised numpy ray casting (slab method) for arbitrary 3D rays,
                depth-image rendering, and the 2D height-band query.
- ``robot``     the simulated robot (body, sensor mounts, servo), its trajectory
                from A to B and back, and the wheel-odometry noise model.
- ``scenario``  ``Scenario``: the built-in scenario, its ground truth (ideal scan,
                obstacle grid), topic names (``TOPICS``) and the bag simulator.
- ``bagio``     helpers to write ROS messages (latched topics, tf) into a bag.
- ``slam``      real 2D SLAM (MRPT rbpf-slam) and localization (pf-localization)
                on recorded scan streams, aligned and scored against the ground truth.

The command-line entry points live beside this folder in ``scripts/``; each adds
``scripts/`` to ``sys.path`` and imports from here.
"""
