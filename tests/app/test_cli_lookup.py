"""``hybobs bench`` and ``hybobs observe powertrain5`` with the lookup-table observer (paper 002): the JSON fields."""

#: "Exact" reconstruction: |x_hat - x| / max(1, |x|) at every step flagged observable (noise-free data).
EXACT_RTOL = 1e-9


def test_cli_bench_json_contract(capsys):
    import json

    from hybobs_opt.cli import main

    code = main(["bench", "powertrain3", "--horizon", "3", "--steps", "1200", "--observers", "lookup", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    rec = out["observers"]["lookup"]
    for key in ("median_step_s", "p95_step_s", "max_abs_error_observable", "n_flagged_unobservable", "solver"):
        assert key in rec
    assert rec["max_abs_error_observable_all"] < 1e-9
    assert rec["batch_equals_steps"] is True
    assert main(["bench", "powertrain3", "--steps", "2"]) == 2
    assert rec["n_fallback"] == 0 and rec["fallback_reasons"] == {}
    assert rec["btilde_test"] == "pairs" and rec["table_seconds"] >= 0


def test_model17_cli_observe_contract(capsys):
    """``hybobs observe powertrain5 --json``: lookup flags, no fallback, no progress bar under --json."""
    import json

    from hybobs_opt.cli import main

    assert main(["observe", "powertrain5", "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    rec = out["observers"]["lookup"]
    assert out["observer"] == "lookup" and rec["n_fallback"] == 0
    assert rec["n_flagged_observable"] > 500 and rec["max_abs_error_observable_all"] < EXACT_RTOL
    assert rec["batch_equals_steps"] is True
    assert captured.err == ""
