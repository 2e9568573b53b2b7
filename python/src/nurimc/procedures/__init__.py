"""Procedures: every multi-step rule of the bus as a generator of actions (motor, group,
discovery, configuration, settings, product lines, backup, restore journal, multi-turn, stop)."""
