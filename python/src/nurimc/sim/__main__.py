"""`python -m nurimc.sim`: the same as `nurimc sim`."""

from .cli import main

main()
