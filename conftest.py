"""Fixtures shared by the pytest files of every package (pytest finds this file at the root it
runs from, the folder of pytest.ini)."""
import os

import pytest


@pytest.fixture(scope="module")
def ros_env(tmp_path_factory):
    """A private roscore for the module's nodes (``Roscore``: a free port, ROS_HOME and logs in a
    temporary folder); yields the environment that reaches it, with log lines that read
    ``[SEVERITY] message`` and reach a pipe at once."""
    from laserscan_toolbox.ros.rosrun import Roscore  # here: files without ROS need no toolbox
    base = dict(os.environ, PYENV_VERSION="system", ROSCONSOLE_FORMAT="[${severity}] ${message}",
                ROSCONSOLE_STDOUT_LINE_BUFFERED="1")
    with Roscore(str(tmp_path_factory.mktemp("ros")), base_env=base) as core:
        yield core.env
