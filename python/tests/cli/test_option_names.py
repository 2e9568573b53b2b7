"""One option name for the product line (--product, global, applied by every command that reads
frames; --line accepted as its alias for one release), and global options after the command
answered with where they go (issue 38)."""

from __future__ import annotations

import json

import pytest

from .inprocess import nurimc

#: An RSA's "set ratio 12.5" to ID 1: mode 09, which in MC's table is "set rated speed".
RSA_SET_RATIO = "fffe01047409007d"


def decoded(*args: str) -> str:
    done = nurimc("--json", *args)
    assert done.code == 0, done.err
    name: str = json.loads(done.out)["frames"][0]["message"]
    return name


def test_the_frame_is_an_rsa_set_ratio() -> None:
    done = nurimc("--json", "--product", "rsa", "encode", "set_ratio", "ratio=12.5", "--to", "1")
    assert json.loads(done.out)["hex"] == RSA_SET_RATIO


@pytest.mark.parametrize(
    "args",
    [
        ("--product", "rsa", "decode", RSA_SET_RATIO),  # global, the one name
        ("--line", "rsa", "decode", RSA_SET_RATIO),  # global, the old spelling
        ("decode", "--product", "rsa", RSA_SET_RATIO),  # the command's own
        ("decode", "--line", "rsa", RSA_SET_RATIO),  # the command's own, the old spelling
        ("--product", "mc", "decode", "--product", "rsa", RSA_SET_RATIO),  # the command's wins
    ],
)
def test_decode_reads_the_frame_with_the_product_given(args: tuple[str, ...]) -> None:
    assert decoded(*args) == "set_ratio"


def test_decode_without_a_product_reads_mc() -> None:
    assert decoded("decode", RSA_SET_RATIO) == "set_rated_speed"
    assert decoded("--product", "blmc-h", "decode", RSA_SET_RATIO) == "set_rated_speed"  # MC's table


def test_encode_takes_the_global_product() -> None:
    done = nurimc("--json", "--line", "rsa", "encode", "set_ratio", "ratio=12.5", "--to", "1")
    assert done.code == 0 and json.loads(done.out)["hex"] == RSA_SET_RATIO, done.err


def test_an_unknown_product_is_one_line() -> None:
    done = nurimc("--product", "zz", "decode", RSA_SET_RATIO)
    assert done.code == 2 and len(done.errors) == 1 and "zz" in done.errors[0], done.err


@pytest.mark.parametrize(
    ("args", "answer"),
    [
        (("status", "--id", "1"), "error: --id is a global option: nurimc --id 1 status"),
        (
            ("--id", "1", "status", "--port", "sim://?ids=1"),
            "error: --port is a global option: nurimc --port sim://?ids=1 --id 1 status",
        ),
        (("scan", "--baud=115200"), "error: --baud is a global option: nurimc --baud=115200 scan"),
        (("ping", "--rs485"), "error: --rs485 is a global option: nurimc --rs485 ping"),
    ],
)
def test_a_global_option_after_the_command_says_where_it_goes(args: tuple[str, ...], answer: str) -> None:
    done = nurimc(*args)
    assert done.code == 2 and done.err.strip() == answer, done.err


def test_a_command_option_of_the_same_name_is_not_taken_for_a_global_one() -> None:
    done = nurimc("sim", "--baud", "nope")  # sim has its own --baud: its own error, not the hint
    assert "global option" not in done.err
