"""The console script: help lists the commands; user errors exit 2 on one line."""

import pytest

from cosim.cli import build_parser, main


def test_help_lists_bench() -> None:
    text = build_parser().format_help()
    assert "bench" in text


def test_unknown_command_is_a_usage_error() -> None:
    with pytest.raises(SystemExit) as exc:
        main(["no-such-command"])
    assert exc.value.code == 2
