"""The benchmark report: a readable table, or one JSON object of the same figures."""

import json

from cosim.bench import median_time, report

RESULT = {
    "title": "demo",
    "rows": [{"case": "a", "median_ms": 1.5}, {"case": "b", "median_ms": 0.25, "n": 3}],
    "ratios": {"speedup": 120.0},
    "targets": {"speedup": ">= 100"},
    "notes": ["measured here"],
}


def test_table_lists_every_row_column_and_ratio() -> None:
    text = report(RESULT)
    lines = text.splitlines()
    header = next(line for line in lines if line.startswith("case"))
    assert header.split() == ["case", "median_ms", "n"]
    assert any(line.split()[:2] == ["a", "1.5"] for line in lines)
    assert "speedup: 120   (target: >= 100)" in text
    assert "note: measured here" in text


def test_json_is_one_object_with_the_same_figures() -> None:
    text = report(RESULT, as_json=True)
    assert "\n" not in text
    assert json.loads(text) == RESULT


def test_median_time_calls_the_function_warmup_plus_repeats_times() -> None:
    calls: list[int] = []
    value = median_time(lambda: calls.append(1), repeats=5, warmup=2)
    assert len(calls) == 7
    assert value >= 0.0
