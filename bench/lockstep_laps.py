#!/usr/bin/env python3
"""The closed loop's judging set: lockstep laps of the shipped tracks over noise seeds.

A lockstep lap (`trajopt closed-loop --lockstep`) repeats bit for bit, so a change to the
closed loop is judged on many of them at once: each track with each noise seed, at the
settings of the circuit targets (`--mismatch default --friction-scale 0.9`). The script
runs the laps `--jobs` at a time and prints, per setting and per track, how many laps met
both targets (CG at least 0.2 m inside every edge, error against the plan at most 0.5 m),
each alone, and how many completed, with the median lap time, edge distance and error.

Two or more `--bin-dir` values compare builds: their laps are interleaved (A, B, A, B...)
so that a slower minute of the machine falls on both. Extra closed-loop options go after
`--`, and apply to every build.

    python3 bench/lockstep_laps.py --bin-dir target/release
    python3 bench/lockstep_laps.py --bin-dir /tmp/a/target/release --bin-dir target/release \
        --seeds 1-4 --tracks Austin,Montreal -- --soft-lane-m 1.6

Needs only the standard library and the release binaries (`cargo build --release
--workspace --bins`). Each lap's JSON is kept in `--out-dir` (one file per build, track and
seed), so a set can be summarised again with `--summarise-only`.
"""

import argparse
import concurrent.futures
import json
import os
import statistics
import subprocess
import sys
import time

TRACKS = ["Austin", "Budapest", "Montreal", "Silverstone", "Spa"]
LANE_TARGET_M = 0.2
ERROR_TARGET_M = 0.5


def seed_list(text):
    """Seeds as `1-8` or `1,3,5`."""
    seeds = []
    for part in text.split(","):
        if "-" in part:
            lo, hi = part.split("-", 1)
            seeds.extend(range(int(lo), int(hi) + 1))
        else:
            seeds.append(int(part))
    if not seeds:
        raise argparse.ArgumentTypeError("no seeds")
    return seeds


def lap_file(out_dir, label, track, seed):
    return os.path.join(out_dir, f"{label}_{track}_seed{seed}.json")


def run_lap(bin_dir, label, track, seed, extra, out_dir):
    """One lockstep lap; returns (label, track, seed, its JSON or an error string)."""
    out = lap_file(out_dir, label, track, seed)
    cmd = [
        os.path.join(bin_dir, "trajopt"),
        "closed-loop",
        "--lockstep",
        "--track",
        track,
        "--mismatch",
        "default",
        "--friction-scale",
        "0.9",
        "--noise-seed",
        str(seed),
        "--bin-dir",
        bin_dir,
        "--out-dir",
        os.path.join(out_dir, f"{label}_{track}_seed{seed}"),
        "--json",
        *extra,
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0 or not proc.stdout.strip():
        tail = proc.stderr.strip().splitlines()[-1:] or ["no output"]
        return label, track, seed, f"exit {proc.returncode}: {tail[0]}"
    try:
        lap = json.loads(proc.stdout)
    except json.JSONDecodeError as err:
        return label, track, seed, f"bad JSON: {err}"
    tmp = out + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(lap, f)
    os.replace(tmp, out)
    return label, track, seed, lap


def judge(lap):
    """(both, lane, error, completed, lap time, edge distance, error) of one lap's JSON."""
    completed = lap.get("laps_completed", 0) >= 1
    margin = lap.get("min_edge_margin_m")
    error = lap.get("max_lateral_error_m")
    lane = bool(lap.get("lane_kept")) and margin is not None and margin >= LANE_TARGET_M
    err_ok = error is not None and error <= ERROR_TARGET_M
    times = lap.get("lap_times_s") or []
    return (
        completed and lane and err_ok,
        completed and lane,
        completed and err_ok,
        completed,
        times[0] if times else None,
        margin,
        error,
    )


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def fmt(value, unit):
    return "-" if value is None else f"{value:.2f} {unit}"


def summarise(labels, tracks, seeds, results, stream):
    """Prints one table per build to `stream` and returns the counts as a dict."""
    summary = {}
    for label in labels:
        rows = []
        totals = [0, 0, 0, 0]
        n_all = 0
        per_track = {}
        for track in tracks:
            judged = []
            failures = []
            for seed in seeds:
                lap = results.get((label, track, seed))
                if isinstance(lap, dict):
                    judged.append(judge(lap))
                elif lap is not None:
                    failures.append(f"seed {seed}: {lap}")
            counts = [sum(1 for j in judged if j[i]) for i in range(4)]
            for i in range(4):
                totals[i] += counts[i]
            n_all += len(seeds)
            lap_t = median([j[4] for j in judged if j[3]])
            edge = median([j[5] for j in judged])
            err = median([j[6] for j in judged])
            per_track[track] = {
                "laps": len(seeds),
                "both": counts[0],
                "lane": counts[1],
                "error": counts[2],
                "completed": counts[3],
                "median_lap_time_s": lap_t,
                "median_min_edge_margin_m": edge,
                "median_max_lateral_error_m": err,
                "failures": failures,
            }
            rows.append(
                f"| {track} | {counts[0]} / {counts[1]} / {counts[2]} / {counts[3]} of "
                f"{len(seeds)} | {fmt(lap_t, 's')} | {fmt(edge, 'm')} | {fmt(err, 'm')} |"
            )
            rows.extend(f"|   {f} | | | |" for f in failures)
        print(f"\n{label}: both / lane / error / completed", file=stream)
        print("| track | counts | median lap | median edge | median error |", file=stream)
        print("| --- | --- | --- | --- | --- |", file=stream)
        print("\n".join(rows), file=stream)
        print(
            f"| all | {totals[0]} / {totals[1]} / {totals[2]} / {totals[3]} of {n_all} | | | |",
            file=stream,
        )
        summary[label] = {
            "both": totals[0],
            "lane": totals[1],
            "error": totals[2],
            "completed": totals[3],
            "laps": n_all,
            "tracks": per_track,
        }
    return summary


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bin-dir", action="append", required=True, help="folder of trajopt, planner_proc, tracker_proc (repeat to compare builds)")
    p.add_argument("--label", action="append", help="a name per --bin-dir (default A, B, ...)")
    p.add_argument("--tracks", default=",".join(TRACKS))
    p.add_argument("--seeds", type=seed_list, default=seed_list("1-8"))
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out-dir", default="out/lockstep_laps")
    p.add_argument("--summarise-only", action="store_true", help="read the laps' JSON already in --out-dir")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object on stdout")
    p.add_argument("extra", nargs="*", help="closed-loop options after --, for every build")
    args = p.parse_args()

    labels = args.label or [chr(ord("A") + i) for i in range(len(args.bin_dir))]
    if len(labels) != len(args.bin_dir):
        p.error("give one --label per --bin-dir")
    for d in args.bin_dir:
        if not os.path.isfile(os.path.join(d, "trajopt")):
            p.error(f"--bin-dir {d}: no trajopt executable there")
    tracks = [t for t in args.tracks.split(",") if t]
    os.makedirs(args.out_dir, exist_ok=True)

    results = {}
    if args.summarise_only:
        for label in labels:
            for track in tracks:
                for seed in args.seeds:
                    path = lap_file(args.out_dir, label, track, seed)
                    if os.path.exists(path):
                        with open(path, encoding="utf-8") as f:
                            results[(label, track, seed)] = json.load(f)
    else:
        # Interleaved: every build's lap of a (track, seed) before the next pair.
        jobs = [
            (d, label, track, seed)
            for track in tracks
            for seed in args.seeds
            for d, label in zip(args.bin_dir, labels)
        ]
        t0 = time.monotonic()
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            futures = [pool.submit(run_lap, d, label, t, s, args.extra, args.out_dir) for d, label, t, s in jobs]
            for fut in concurrent.futures.as_completed(futures):
                label, track, seed, lap = fut.result()
                results[(label, track, seed)] = lap
                if isinstance(lap, dict):
                    b, l, e, c, t, m, err = judge(lap)
                    note = f"lap {fmt(t, 's')}, edge {fmt(m, 'm')}, error {fmt(err, 'm')}"
                else:
                    note = lap
                print(f"[{time.monotonic() - t0:6.0f} s] {label} {track} seed {seed}: {note}", file=sys.stderr)
    summary = summarise(labels, tracks, args.seeds, results, sys.stderr if args.json else sys.stdout)
    if args.json:
        json.dump(summary, sys.stdout)
        print()


if __name__ == "__main__":
    main()
