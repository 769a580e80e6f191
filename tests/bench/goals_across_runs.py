#!/usr/bin/env python3
"""The goals of urs-bench across several full runs: one Markdown table, a column per run.

    goals_across_runs.py RUN1.json RUN2.json ...   (urs-bench --json files)

A run may be several files joined by commas (RUN1.json,WAN1.json: urs-bench's and wan_bench.sh's
of the same run), their rows and measurements taken together.

A latency goal is a ratio to a baseline measured in the same run (the row's median ratio, with
the spread of its per-repetition ratios); a throughput, stream, discovery, memory or recovery goal
is the value urs-bench reports with its goal. The state says whether every run met the goal, none
did, or some did, and how far the ratios of the runs lie apart (max/min - 1)."""
import json
import re
import sys


def latency_goals(runs):
    keys = []
    for run in runs:
        for row in run["rows"]:
            key = (row["path"], row["payload"])
            if row.get("goal", 0) > 0 and key not in keys:
                keys.append(key)
    for path, payload in keys:
        cells, met, ratios, goal, baseline = [], [], [], None, ""
        for run in runs:
            row = next((r for r in run["rows"] if (r["path"], r["payload"]) == (path, payload)), None)
            if row is None or "ratio" not in row:
                cells.append("–")
                continue
            goal = row["goal"]
            baseline = row["baseline"].split("|")[0]
            ratios.append(row["ratio"])
            met.append(row["ratio"] <= goal)
            spread = f" ({row['ratio_low']:.2f}–{row['ratio_high']:.2f})" if "ratio_low" in row else ""
            cells.append(f"{row['ratio']:.2f}×{spread}")
        yield f"{path} ≤ {goal:g}× {baseline}, {payload}", cells, met, ratios


GOAL_IN_TEXT = re.compile(r"\(goal (?P<goal>[^)]*?)(?:: (?P<state>met|missed))?\)")


def other_goals(runs):
    keys = []
    for run in runs:
        for key, text in run["other"].items():
            if "goal" in text and key not in keys:
                keys.append(key)
    for key in keys:
        cells, met, goal = [], [], ""
        for run in runs:
            text = run["other"].get(key)
            if text is None:
                cells.append("–")
                continue
            match = GOAL_IN_TEXT.search(text)
            goal = match.group("goal") if match else goal
            value = GOAL_IN_TEXT.sub("", text).strip().rstrip(";,")
            cells.append(value)
            state = match.group("state") if match else None
            met.append(state == "met" if state else judged(value, goal))
        yield f"{key} (goal {goal})", cells, met, []


def number(pattern, text):
    found = re.search(pattern, text)
    return float(found.group(1)) if found else None


def judged(value, goal):
    """The goals urs-bench gives without a verdict: a stream's rate and losses, a median or a
    maximum in ms, a size in KiB. None when the text says neither."""
    rate, lost = number(r"([\d.]+) frames/s", value), number(r"(\d+) lost", value)
    if rate is not None and lost is not None:
        return rate >= (number(r"goal ([\d.]+)/s", "goal " + goal) or 0) and lost == 0
    bound = number(r"<= ([\d.]+)", goal)
    if bound is None:
        return None
    if "KiB" in goal:
        return (number(r"([\d.]+) KiB", value) or float("inf")) <= bound
    if goal.startswith("median"):
        return (number(r"median ([\d.]+) ms", value) or float("inf")) <= bound
    return (number(r"max ([\d.]+) ms", value) or number(r"median ([\d.]+) ms", value) or float("inf")) <= bound


def state_of(met, ratios):
    known = [m for m in met if m is not None]
    if not known:
        return "see the values"
    if all(known):
        state = f"met in {len(known)} of {len(known)}"
    elif not any(known):
        state = f"missed in {len(known)} of {len(known)}"
    else:
        state = f"met in {sum(known)} of {len(known)}"
    if len(ratios) > 1:
        state += f"; runs {100 * (max(ratios) / min(ratios) - 1):.0f} % apart"
    return state


def load_run(paths):
    """One run from one file or several joined by commas."""
    run = {"rows": [], "other": {}}
    for path in paths.split(","):
        part = json.load(open(path))
        run["rows"] += part["rows"]
        run["other"].update(part["other"])
    return run


def main(paths):
    runs = [load_run(p) for p in paths]
    head = "| goal | " + " | ".join(f"run {i + 1}" for i in range(len(runs))) + " | state |"
    print(head)
    print("|" + "---|" * (len(runs) + 2))
    for goal, cells, met, ratios in list(latency_goals(runs)) + list(other_goals(runs)):
        print(f"| {goal} | " + " | ".join(cells) + f" | {state_of(met, ratios)} |")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
