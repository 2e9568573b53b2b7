"""Global options given after the command: say where they go instead of "No such option".

`nurimc status --id 1` is a natural thing to type; click answers "No such option: --id". The
flags without a value (--json, -v) are moved to the front by app.global_flags_first; the options
with a value stay an error (a command may have an option of the same name, e.g. `sim --baud`),
but the error shows the command line that works: "--id is a global option: nurimc --id 1 status".
"""

from __future__ import annotations

#: The global options with a value, and the global flags that global_flags_first does not move.
GLOBAL_VALUED = ("--port", "-p", "--baud", "-b", "--id", "-i", "--product", "--line", "--port-wait")
GLOBAL_FLAGS = ("--rs485", "--rs485-invert")


def where_it_goes(option: str | None, args: list[str]) -> str | None:
    """The one-line answer for a global option found after the command, or None if `option` is
    not a global option (or cannot be found in `args`)."""
    if option is None:
        return None
    name = option.split("=", 1)[0]
    if name not in GLOBAL_VALUED and name not in GLOBAL_FLAGS:
        return None
    for at, token in enumerate(args):
        if token == "--":
            break
        if token.split("=", 1)[0] != name or (token == name and at == 0):
            continue
        taken = [token]
        if name in GLOBAL_VALUED and "=" not in token and at + 1 < len(args):
            taken.append(args[at + 1])
        rest = args[:at] + args[at + len(taken) :]
        fixed = " ".join(["nurimc", *taken, *rest])
        return f"{name} is a global option: {fixed}"
    return None
