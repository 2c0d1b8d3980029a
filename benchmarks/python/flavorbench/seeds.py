"""Tables of a scene's runs pooled over seeds.  Each seed's JSON holds "runs"; a run names its "integrator" and
"step_fs", holds each observable as [value, block error] and, when it did not finish, a true "failed".  A table gives,
per peer, the mean over the seeds ± its standard error and, in brackets, its difference from the first peer (the
reference) in combined standard errors."""
import json

import numpy as np

from .ensemble import mean_se


def load_runs(files):
    """Every run of the JSON files, failed ones included."""
    runs = []
    for path in files:
        with open(path) as f:
            runs += json.load(f)["runs"]
    return runs


def steps_of(runs, integrator, keep=lambda run: True):
    """The steps (fs) at which `integrator` ran, ascending."""
    return sorted({r["step_fs"] for r in runs if r["integrator"] == integrator and keep(r)})


def runs_at(runs, integrator, step_fs):
    return [r for r in runs if r["integrator"] == integrator and r["step_fs"] == step_fs]


def step_columns(runs, integrator, name, keep=lambda run: True, mark_wall=True):
    """One table column per step of `integrator`: ("NAME H fs", its runs), " + wall" added where the runs had a hard
    wall (wall_nm > 0) and mark_wall."""
    columns = []
    for h in steps_of(runs, integrator, keep):
        peers = runs_at(runs, integrator, h)
        wall = " + wall" if mark_wall and peers[0].get("wall_nm", 0) > 0 else ""
        columns.append((f"{name} {h:g} fs{wall}", peers))
    return columns


def drude_peer_columns(reference_runs, runs, reference_step, mark_sim_wall=True):
    """The columns of a Drude scene's seed table: DrudeLangevin at reference_step (fs) from reference_runs, then
    DrudeLangevin at every other step and the SIM (WarpedMiddle) at every step from runs."""
    columns = [(f"DrudeLangevin {reference_step:g} fs (reference)",
                runs_at(reference_runs, "DrudeLangevin", reference_step))]
    columns += step_columns(runs, "DrudeLangevin", "DrudeLangevin", lambda r: r["step_fs"] != reference_step)
    columns += step_columns(runs, "WarpedMiddle", "SIM", mark_wall=mark_sim_wall)
    return columns


def pooled(runs, key, scale=1.0, within=False):
    """(mean, standard error) over the finished runs' values of `key`, or None with fewer than two.  within: the
    error from each run's own block error instead of the spread between runs (sqrt(sum e_i^2) / n; one run is enough):
    steadier than the spread of two or three runs."""
    finished = [r[key] for r in runs if not r.get("failed") and key in r]
    values = np.array([v[0] * scale for v in finished])
    if within and finished:
        return values.mean(), np.sqrt(sum((v[1] * scale)**2 for v in finished)) / len(finished)
    return mean_se(values) if len(values) > 1 else None


def markdown(columns, rows, within=False, peers_as_rows=False):
    """The Markdown table: columns [(name, runs)], the first the reference; rows [(key, name, format, scale)]; within:
    errors as pooled(within=True).  The last row counts the finished runs of each column ("n of m" where some
    failed).  peers_as_rows: the same table transposed, a row per peer and a column per observable."""
    table = [["observable"] + [name for name, _ in columns]]
    for key, name, fmt, scale in rows:
        cells, reference = [name], pooled(columns[0][1], key, scale, within)
        for index, (_, runs) in enumerate(columns):
            value = pooled(runs, key, scale, within)
            cell = "—" if value is None else (fmt % value[0]) + " ± " + (fmt % value[1])
            if value is not None and index and reference is not None:
                cell += " (%+.1f)" % ((value[0] - reference[0]) / np.hypot(value[1], reference[1]))
            cells.append(cell)
        table.append(cells)
    counts = ["runs"]
    for _, runs in columns:
        finished = sum(1 for r in runs if not r.get("failed"))
        counts.append(str(finished) if finished == len(runs) else f"{finished} of {len(runs)}")
    table.append(counts)
    if peers_as_rows:
        table = [list(row) for row in zip(*table)]
        table[0][0] = "peer"
    lines = ["| " + " | ".join(table[0]) + " |", "|---" * len(table[0]) + "|"]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in table[1:]])


def print_table_or_parse_peers(parser, args, table, parse_peer):
    """The command line of the replica scripts: with --seed-table, prints table(files, reference) and returns None;
    otherwise returns [parse_peer(text) for each --peers].  A ValueError of either, or no --peers, is the parser's
    error (it exits)."""
    try:
        if args.seed_table:
            print(table(args.seed_table, args.reference))
            return None
        if not args.peers:
            parser.error("--peers is required (or --seed-table)")
        return [parse_peer(text) for text in args.peers]
    except ValueError as error:
        parser.error(str(error))
