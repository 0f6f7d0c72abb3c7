"""The seeds' demo programs as nodes (MTC demos, move_group exercises, scan-n-plan); the tasks
and workflows they run are built in mycobot_planning.demos."""
