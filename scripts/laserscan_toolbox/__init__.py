"""Tools of the unified laser-scan toolbox (ROS 1), one importable package in layers.

Sub-packages, lowest layer first (a module imports only from its own layer or below; the
test test/test_toolbox_layers.py checks it):

- ``ros``          running ROS pieces (private master, roslaunch, rosbag play, CPU meters),
                   writing bags, rviz configurations and screenshots.
- ``config_check`` the schema of every node parameter and the YAML / launch / live checks
                   (a module of its own: it imports nothing of the toolbox).
- ``simulation``   the shop-floor world, ray casting, the simulated robot and the scenario
                   with its ground truth and bag simulator.
- ``evaluation``   playing a bag through the pipeline and recording its outputs, the
                   analysis against the ground truth, metrics, mapping, SLAM and the reports.
- ``experiments``  the benchmarks and experiments built on the evaluation (CPU against depth
                   points, transport, camera path, soak) and the node fuzz's inputs.

Nothing is imported here, so that a tool only pays for what it uses. The command-line entry
points live beside this folder in ``scripts/`` and call a module's ``main``; nothing sets a path
(CONTRIBUTING.md, "How the toolbox is found"): run from the source tree, Python finds this
package beside the script; scan_evaluation_tools installs it (its ``setup.py``,
``catkin_python_setup``) and the tools a robot runs, which import it through the Python path of
the sourced devel or install space; pytest gets it from ``pytest.ini``.
"""
