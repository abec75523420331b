"""One run of a scenario: the loop and its parts (ego, observer, recorder, metrics, outputs)."""
