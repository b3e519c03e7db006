"""ROS helpers of the tools: a private master, roslaunch, rosbag play and CPU meters
(``rosrun``), the CPU time of processes (``cpu_accounting``), writing bags (``bagio``), rviz
configurations (``rviz_config``) and screenshots (``rviz_shot``). The lowest layer: imports
nothing else of the toolbox."""
