"""The port URL allow-list under hypothesis (issue 39, item 8): from the page, only serial
devices and sim:// without a state directory; every other scheme, and anything that names a
file outside /dev, is refused with a one-line reason."""

from __future__ import annotations

from urllib.parse import parse_qs, urlsplit

from hypothesis import example, given, settings
from hypothesis import strategies as st

from nurimc.dashboard.security import port_refusal

SCHEMES = st.sampled_from(["spy", "socket", "rfc2217", "loop", "alt", "hwgrep", "cp2110", "sim", "SIM", "Sim", "file",
                           "http", "x"])  # fmt: skip
QUERY = st.lists(
    st.tuples(st.sampled_from(["ids", "baud", "state", "STATE", "State", "file", "seed", "motor", "state "]),
              st.text(max_size=12)),
    max_size=4,
)  # fmt: skip


@settings(max_examples=300, deadline=None)
@given(scheme=SCHEMES, rest=st.text(max_size=30), query=QUERY)
@example(scheme="sim", rest="[", query=[])  # an unclosed '[': urlsplit's "Invalid IPv6 URL" (found by this test)
def test_only_the_plain_simulator_passes_among_urls(scheme: str, rest: str, query: list[tuple[str, str]]) -> None:
    url = f"{scheme}://{rest}" + ("?" + "&".join(f"{k}={v}" for k, v in query) if query else "")
    refusal = port_refusal(url)
    if refusal is None:
        assert scheme.lower() == "sim"
        options = parse_qs(urlsplit(url.strip()).query, keep_blank_values=True)
        assert not any(name.lower() == "state" for name in options), url
        assert all(ord(ch) >= 32 for ch in url.strip())  # the port is opened stripped (commands._open_bus)
    else:
        assert "\n" not in refusal and refusal


@settings(max_examples=300, deadline=None)
@given(path=st.text(max_size=40))
def test_paths_pass_only_as_devices(path: str) -> None:
    refusal = port_refusal(path)
    if refusal is None and "://" not in path:
        text = path.strip()
        device = text.startswith("/dev/") and "/../" not in text + "/"
        windows = text.upper().removeprefix("\\\\.\\").startswith("COM")
        assert device or windows, path
    if refusal is not None:
        assert "\n" not in refusal
