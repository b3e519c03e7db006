"""The simulator: the world (``world``), ray casting (``raycast``), the robot and its
odometry (``robot``), and the scenario with its ground truth and bag writer (``scenario``).
Imports only ``ros`` of the toolbox (to write bags)."""
