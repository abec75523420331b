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


def _usage_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run `cosim argv`, expect exit 2, return stderr (asserted to be one line)."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("cosim"), err
    return err


@pytest.mark.parametrize("argv", [
    [],
    ["run"],
    ["run", "a.toml", "b.toml"],
    ["run", "a.toml", "--controller", "mim"],
    ["bench"],
    ["bench", "control", "--repeats", "two"],
    ["batch", "--workers", "many"],
    ["track", "--case", "6"],
])
def test_argparse_errors_are_one_line(argv: list[str],
                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert "usage" not in _usage_error(argv, capsys)


@pytest.mark.parametrize(("argv", "hint"), [
    (["run", "x.toml", "--controler", "mimo"], "--controller"),
    (["bench", "control", "--repets", "3"], "--repeats"),
    (["track", "--cornering-sacle", "0.6"], "--cornering-scale"),
    (["run", "x.toml", "--controller", "mim"], "mimo"),
    (["bench", "planer"], "planner"),
])
def test_misspelt_flag_gets_did_you_mean(argv: list[str], hint: str,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert f"did you mean '{hint}'?" in _usage_error(argv, capsys)


@pytest.mark.parametrize(("argv", "allowed"), [
    (["bench", "batch", "--workers", "0"], "an integer in [1, "),
    (["bench", "batch", "--repeats", "-2"], "an integer >= 1"),
    (["bench", "control", "--repeats", "0"], "an integer >= 1"),
    (["bench", "control", "--duration", "-1"], "(0, 600] s"),
    (["bench", "control", "--duration", "inf"], "(0, 600] s"),
    (["bench", "cosim", "--duration", "0"], "(0, 3600] s"),
    (["bench", "planner", "--loop-repeats", "0"], "an integer >= 1"),
])
def test_bench_flags_are_checked(argv: list[str], allowed: str,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    err = _usage_error(argv, capsys)
    assert allowed in err and argv[2] in err


def test_gui_without_a_display_is_one_line_at_once(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import time
    from pathlib import Path

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    case1 = Path(__file__).resolve().parents[1] / "scenarios" / "paper_case1_overtaking.toml"
    start = time.perf_counter()
    assert main(["run", str(case1), "--gui", "--out", "/nonexistent/never"]) == 2
    assert time.perf_counter() - start < 5.0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--gui" in err and "display" in err


def test_variant_folders_are_named_after_the_overriding_flags() -> None:
    from pathlib import Path

    from cosim.commands import overridden, variant_folder

    results = Path("results")
    assert variant_folder(results, "case", {"controller": None, "seed": None}) == results / "case"
    assert variant_folder(results, "case", {"controller": "siso", "seed": 3}) == (
        results / "case--controller_siso--seed_3")
    assert variant_folder(results, "track", {"mu": 0.8, "vehicle": "commonroad/x y"}) == (
        results / "track--mu_0.8--vehicle_commonroad_x_y")
    assert overridden("mimo", "mimo") is None and overridden(1, 2) == 2


@pytest.mark.sumo
def test_run_writes_under_the_current_folder_one_folder_per_variant(
        tmp_path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """Two runs of one scenario with other flags keep two folders, under ./results/ of
    the current directory (not the install's), and each prints its own folder."""
    from pathlib import Path

    case1 = Path(__file__).resolve().parents[1] / "scenarios" / "paper_case1_overtaking.toml"
    monkeypatch.chdir(tmp_path)
    written = []
    for flags in (["--controller", "sumo"], ["--controller", "sumo", "--seed", "2"]):
        assert main(["run", str(case1), "--no-figures", *flags]) == 0
        written.append(capsys.readouterr().err.strip().splitlines()[-1])
    assert written == ["wrote results/paper_case1_overtaking--controller_sumo",
                       "wrote results/paper_case1_overtaking--controller_sumo--seed_2"]
    for line in written:
        assert (tmp_path / line.split()[-1] / "metrics.csv").is_file()
