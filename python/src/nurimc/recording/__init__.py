"""Recordings of the bus: MCAP files of ROS 2 messages (`nurimc record --mcap FILE`)."""
