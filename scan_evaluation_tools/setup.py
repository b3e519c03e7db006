"""The Python toolbox (scripts/laserscan_toolbox) as a Python package of scan_evaluation_tools.

catkin_python_setup() in this package's CMakeLists.txt reads this file: the devel space gets a
relay to the source tree, the install space a copy in its Python folder, so that an installed
tool imports the toolbox through the normal Python path. The toolbox stays in scripts/, beside
the command-line tools that run it from a source tree; every sub-package found there is part
of it (no list to keep up to date). Why this package owns it: CONTRIBUTING.md.
"""
import os
import warnings

from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import find_packages, setup

# catkin 0.8's install step runs `setup.py install`, the only way it installs a Python package;
# setuptools 66 (Debian 12) warns that this is deprecated on every install, a message for
# catkin that catkin build would report as this package's warning.
warnings.filterwarnings("ignore", message="setup.py install is deprecated")

# Relative to this file's folder, as catkin requires (catkin runs this file from that folder).
TOOLBOX_PARENT = os.path.join("..", "scripts")

setup(**generate_distutils_setup(
    packages=find_packages(TOOLBOX_PARENT, include=["laserscan_toolbox", "laserscan_toolbox.*"]),
    package_dir={"": TOOLBOX_PARENT},
    # check_config's schema: the export of the C++ parameter tables (parameter_tables.py).
    package_data={"laserscan_toolbox": ["parameter_tables.json"]},
))
