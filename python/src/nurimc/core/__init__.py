"""Sans-I/O layer: the actions procedures yield, the clock, timing, the handle mechanism and
the bus core (BusCore). Knows nothing of ports, sockets or threads."""
