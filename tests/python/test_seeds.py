"""flavorbench.seeds: runs pooled over seeds, against a computation by hand; failed runs counted, not pooled."""
import json
import math

from flavorbench import seeds

ROWS = [("t", "T (K)", "%.2f", 1), ("w", "width (pm)", "%.1f", 1000)]


def write_seed(path, runs):
    with open(path, "w") as f:
        json.dump({"runs": runs}, f)
    return str(path)


def test_a_table_pools_each_peer_over_the_seeds_and_counts_the_failed_runs(tmp_path):
    files = [write_seed(tmp_path / "s1.json", [
        {"integrator": "DrudeLangevin", "step_fs": 0.5, "t": [300.0, 1.0], "w": [0.0020, 0]},
        {"integrator": "WarpedMiddle", "step_fs": 2.0, "t": [297.0, 1.0], "w": [0.0030, 0]},
        {"integrator": "WarpedMiddle", "step_fs": 2.5, "failed": "NaN at step 40"}]),
        write_seed(tmp_path / "s2.json", [
        {"integrator": "DrudeLangevin", "step_fs": 0.5, "t": [302.0, 1.0], "w": [0.0024, 0]},
        {"integrator": "WarpedMiddle", "step_fs": 2.0, "t": [299.0, 1.0], "w": [0.0032, 0]},
        {"integrator": "WarpedMiddle", "step_fs": 2.5, "t": [298.0, 1.0], "w": [0.0030, 0]}])]
    runs = seeds.load_runs(files)
    assert seeds.steps_of(runs, "WarpedMiddle") == [2.0, 2.5]
    assert seeds.steps_of(runs, "DrudeLangevin", lambda r: r["step_fs"] != 0.5) == []
    assert len(seeds.runs_at(runs, "WarpedMiddle", 2.5)) == 2
    mean, se = seeds.pooled(seeds.runs_at(runs, "DrudeLangevin", 0.5), "t")
    assert (mean, se) == (301.0, 1.0)                      # sample standard deviation sqrt(2) over sqrt(2)
    assert seeds.pooled(seeds.runs_at(runs, "WarpedMiddle", 2.5), "t") is None   # one finished run
    columns = [("ref", seeds.runs_at(runs, "DrudeLangevin", 0.5)), ("SIM 2", seeds.runs_at(runs, "WarpedMiddle", 2.0)),
               ("SIM 2.5", seeds.runs_at(runs, "WarpedMiddle", 2.5))]
    lines = seeds.markdown(columns, ROWS).splitlines()
    assert lines[0] == "| observable | ref | SIM 2 | SIM 2.5 |"
    t = (298.0 - 301.0) / math.hypot(1.0, 1.0)
    assert lines[2] == "| T (K) | 301.00 ± 1.00 | 298.00 ± 1.00 (%+.1f) | — |" % t
    assert lines[3] == "| width (pm) | 2.2 ± 0.2 | 3.1 ± 0.1 (%+.1f) | — |" % ((3.1 - 2.2) / math.hypot(0.1, 0.2))
    assert lines[4] == "| runs | 2 | 2 | 1 of 2 |"


def test_within_run_errors_pool_each_runs_block_error():
    runs = [{"t": [300.0, 0.3]}, {"t": [302.0, 0.4]}, {"t": [0.0, 9.0], "failed": "NaN"}]
    mean, se = seeds.pooled(runs, "t", within=True)
    assert mean == 301.0 and math.isclose(se, 0.25)         # sqrt(0.3^2 + 0.4^2) / 2
    assert seeds.pooled(runs[:1], "t", within=True) == (300.0, 0.3)   # one run is enough
    lines = seeds.markdown([("a", runs[:1]), ("b", runs[1:2])], [("t", "T", "%.1f", 1)], within=True).splitlines()
    assert lines[2] == "| T | 300.0 ± 0.3 | 302.0 ± 0.4 (%+.1f) |" % (2.0 / 0.5)
