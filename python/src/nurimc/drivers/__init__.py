"""Drivers: carry out the actions of the sans-I/O procedures on a real port, blocking (sync) or
awaited (aio), through one trampoline (perform)."""
