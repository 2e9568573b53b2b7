"""Listening address, token and the Host / Origin checks."""

from __future__ import annotations

import pytest

from nurimc.dashboard.security import ListenAddress, ListenError, SecurityPolicy, parse_listen

TOKEN = "a-long-enough-secret-token"


@pytest.mark.parametrize(
    ("text", "host", "port"),
    [("127.0.0.1:8485", "127.0.0.1", 8485), ("[::1]:9000", "::1", 9000), (":80", "0.0.0.0", 80), ("h:0", "h", 0)],
)
def test_listen_addresses_parse(text: str, host: str, port: int) -> None:
    assert parse_listen(text) == ListenAddress(host, port)


@pytest.mark.parametrize("text", ["127.0.0.1", "::1:80", "host:http", "host:70000"])
def test_malformed_listen_addresses_are_refused(text: str) -> None:
    with pytest.raises(ListenError, match="--listen"):
        parse_listen(text)


def test_loopback_needs_no_token_but_other_addresses_do() -> None:
    assert SecurityPolicy.build(parse_listen("127.0.0.1:8485"), None).token is None
    assert SecurityPolicy.build(parse_listen("localhost:8485"), None).token is None
    for address in ("0.0.0.0:8485", "192.168.1.5:8485", "[::]:8485"):
        with pytest.raises(ListenError, match="give --token"):
            SecurityPolicy.build(parse_listen(address), None)
    assert SecurityPolicy.build(parse_listen("0.0.0.0:8485"), TOKEN).token == TOKEN


def test_short_tokens_are_refused() -> None:
    with pytest.raises(ListenError, match="at least 16"):
        SecurityPolicy.build(parse_listen("0.0.0.0:1"), "short")


def test_host_check_refuses_rebinding_names() -> None:
    policy = SecurityPolicy.build(parse_listen("127.0.0.1:8485"), None)
    assert policy.host_allowed("127.0.0.1:8485")
    assert policy.host_allowed("localhost:8485")
    assert policy.host_allowed("[::1]:8485")
    assert not policy.host_allowed("evil.example:8485")
    assert not policy.host_allowed(None)
    wildcard = SecurityPolicy.build(parse_listen("0.0.0.0:8485"), TOKEN)
    assert wildcard.host_allowed("bench-pc.local:8485")  # guarded by the token instead


def test_origin_must_be_the_console_itself() -> None:
    policy = SecurityPolicy.build(parse_listen("127.0.0.1:8485"), None)
    assert policy.origin_allowed("http://127.0.0.1:8485", "127.0.0.1:8485")
    assert not policy.origin_allowed("http://evil.example", "127.0.0.1:8485")
    assert not policy.origin_allowed("http://127.0.0.1:9999", "127.0.0.1:8485")
    assert not policy.origin_allowed("null", "127.0.0.1:8485")
    assert not policy.origin_allowed(None, "127.0.0.1:8485")


def test_token_comparison() -> None:
    policy = SecurityPolicy.build(parse_listen("0.0.0.0:1"), TOKEN)
    assert policy.token_ok(TOKEN)
    assert not policy.token_ok(TOKEN[:-1])
    assert not policy.token_ok(None)
