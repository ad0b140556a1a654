#!/usr/bin/env python3
"""Minimum lap time of the planner's car on a closed track: a periodic whole-lap
minimum-time OCP solved by IPOPT (MUMPS) through CasADi, independent of the Rust planner.

The reference a closed-loop lap is measured against. Model and path constraints are
bench/external/casadi_compare.py's (imported, not copied): the single-track model of the
paper's eq. (1) with the vehicle file's resolutions R1-R10, the planner's scaling, the
control box, tire saturation (R5) at (x_k, u_k), the front friction rows (R9) at both ends
of each interval, V_wr >= V_wr_min (R10), the control-rate rows in the multiplied form and
the steering-slew term of the objective. What differs from the planner's 250 m problem:

* the whole lap, N = round(L / spacing) intervals of ds = L / N (spacing 2.5 m by default);
* periodic: x_N = x_0 for every state but s and t (so dpsi_0 and e_0 are free and equal to
  their end values), s_0 = t_0 = 0, and the rate and slew rows also join u_{N-1} to u_0;
* lane e_min = -w_right + margin, e_max = w_left - margin (margin 1 m by default);
* transcription: trapezoidal by default (x_{k+1} = x_k + ds/2 (f(x_k, u_k) + f(x_{k+1}, u_k)),
  second order; `--integrator ie` gives the planner's implicit Euler). The minimum lap time
  is a property of the continuous problem, and at 2.5 m implicit Euler's first-order error
  is a few tenths of a percent of t (config/reference/README-reference-solutions.md: oval
  IE 13.070 s, trapezoidal 13.020 s, the IE controls re-integrated exactly 13.040 s), the
  same order as the differences the reference is there to judge.

Initial guess (quasi-steady speed profile): v_lim = min(v_max, sqrt(GUESS_LAT mu g / |kappa|))
on the centreline, then a forward pass v_{k+1}^2 <= v_k^2 + 2 a_acc ds and a backward pass
v_k^2 <= v_{k+1}^2 + 2 a_brk ds, each twice around the lap (periodic); a_acc and a_brk come
from the rear-axle and total friction limits (see `speed_guess`). The other states follow
from steady cornering and the longitudinal acceleration of that profile: r = V kappa,
beta = 0, V_wr = V, dFz = m a_x h_cg / L, e = dpsi = 0, t = the time of the profile; the
controls: delta = L kappa, the drive or brake torque of m a_x (braking split by the static
axle loads).

Setup (offline, not in CI): python3 -m venv .venv && .venv/bin/pip install -r
bench/external/requirements.txt. Run from the repository root:
    .venv/bin/python bench/external/lap_reference.py --tracks Austin,Budapest,Montreal,Silverstone,Spa,oval
    .venv/bin/python bench/external/lap_reference.py --tracks Montreal --spacing 1.25 --no-write
    .venv/bin/python bench/external/lap_reference.py --check
    .venv/bin/python bench/external/lap_reference.py --mismatch default --tracks Austin,Budapest,Montreal,Silverstone,Spa
    .venv/bin/python bench/external/lap_reference.py --compare-segments
    .venv/bin/python bench/external/lap_reference.py --segments S02,S10 --integrator ie --steering-slew-weight 0
It merges one [[tracks]] entry per (track, edge margin) into config/reference/lap_times.toml
and writes config/reference/<name>_lap_speed.csv (s, V, e, t every ~5 m). `--segments`
solves the planner's open 250 m windows with the same code (against
config/reference/segments_ie_ipopt.csv); `--compare-segments` sets the written Austin lap
beside them. Method, checks and results: docs/lap-reference.md.
"""
import argparse
import csv
import fcntl
import math
import os
import subprocess
import sys
import time
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import casadi_compare as cc  # noqa: E402  (sets the one-thread environment, imports casadi)
from casadi_compare import BETA, DFZ, DPSI, E, NU, NX, R, S, T, U_NOMINAL, V, VWR, X_NOMINAL  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

SCRIPT_VERSION = "1"
SHIPPED = ["Austin", "Budapest", "Montreal", "Silverstone", "Spa", "oval"]
GUESS_LAT = 0.85  # fraction of mu g the guess uses in corners (the car's lateral limit is below mu g)
CSV_STEP_M = 5.0  # approximate spacing of the written speed profile


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tracks", default=",".join(SHIPPED), help="names in config/tracks/tracks.toml and/or oval")
    ap.add_argument("--root", default="config", help="data root (holds tracks/, scenarios/, vehicles/)")
    ap.add_argument("--vehicle", default="config/vehicles/lc500.toml")
    ap.add_argument("--spacing", type=float, default=2.5, help="target node spacing [m]")
    ap.add_argument("--edge-margin-m", type=float, default=1.0)
    ap.add_argument("--integrator", choices=("trapezoidal", "ie"), default="trapezoidal")
    ap.add_argument("--steering-slew-weight", type=float, default=None,
                    help="default: the scenario file's (segments.toml for tracks, oval.toml)")
    ap.add_argument("--friction-scale", type=float, default=1.0,
                    help="scale the friction and the brake torque limits (trajopt closed-loop --friction-scale)")
    ap.add_argument("--v-max-mps", type=float, default=None,
                    help="speed cap instead of the scenario's (trajopt closed-loop --track-v-max-mps)")
    ap.add_argument("--mismatch", default=None,
                    help="the tracker plant's car: 'default' (config/mismatch/default.toml) or a mismatch "
                         "file, its [vehicle] changes applied as ipc::mismatch::Mismatch::apply does "
                         "(trajopt closed-loop --mismatch); written to lap_times_plant_<file stem>.toml")
    ap.add_argument("--max-iter", type=int, default=3000)
    ap.add_argument("--print-level", type=int, default=0, help="IPOPT print_level")
    ap.add_argument("--out", default="config/reference", help="folder of lap_times.toml and the speed CSVs")
    ap.add_argument("--no-write", action="store_true", help="print the results only")
    ap.add_argument("--check", action="store_true", help="solve a coarse oval lap and verify it (seconds)")
    ap.add_argument("--segments", default="",
                    help="no lap: solve these segments of scenarios/segments.toml as the planner's open "
                         "window (free initial state, dpsi_0 = 0), next to segments_ie_ipopt.csv")
    ap.add_argument("--free-heading", action="store_true", help="with --segments: dpsi_0 free")
    ap.add_argument("--compare-segments", action="store_true",
                    help="no solve: the Austin lap's time over each 250 m segment of scenarios/segments.toml "
                         "next to the segment's minimum time (config/reference/segments_ie_ipopt.csv)")
    return ap.parse_args(argv)


class Road:
    """A closed road: lap length, k_ref(s), e bounds, and the scenario settings the planner
    uses on it (speed bounds, saturation, slew weight)."""

    def __init__(self, name, lap, kappa_at, e_at, settings):
        self.name, self.lap = name, lap
        self.kappa_at, self.e_at = kappa_at, e_at  # vectorised over s (wrapped modulo the lap)
        self.v_min, self.v_max = settings["v_min_mps"], settings["v_max_mps"]
        self.saturation = settings["enforce_tire_saturation"]
        self.slew = settings["steering_slew_weight"]


def load_toml(path):
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as err:
        sys.exit(f"{path}: {err}")


def track_road(root, name, margin):
    """A track of tracks.toml: the 1 m profile interpolated linearly and periodically; the
    settings of segments.toml's [defaults]."""
    index_path = os.path.join(root, "tracks", "tracks.toml")
    entry = next((t for t in load_toml(index_path).get("tracks", []) if t.get("name") == name), None)
    if entry is None:
        sys.exit(f"{index_path}: no track named {name!r}")
    lap = float(entry["lap_length_m"])
    path = os.path.join(root, entry["profile_csv"])
    rows = []
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header != ["s_m", "kappa_1pm", "w_right_m", "w_left_m"]:
            sys.exit(f"{path}: header {header} (expected s_m,kappa_1pm,w_right_m,w_left_m)")
        for i, row in enumerate(reader, start=2):
            try:
                vals = [float(v) for v in row]
            except ValueError:
                sys.exit(f"{path}: row {i}: not four numbers: {row}")
            if len(vals) != 4 or not all(math.isfinite(v) for v in vals):
                sys.exit(f"{path}: row {i}: not four finite numbers: {row}")
            rows.append(vals)
    a = np.array(rows)
    if np.any(np.diff(a[:, 0]) <= 0) or a[-1, 0] >= lap:
        sys.exit(f"{path}: s must increase and stay below lap_length_m = {lap}")
    ext = np.vstack([a, a[:1] + [lap, 0, 0, 0]])  # row 0 again at s = lap

    def interp(col):
        return lambda s: np.interp(np.mod(s, lap), ext[:, 0], ext[:, col])

    k, wr, wl = interp(1), interp(2), interp(3)
    settings = dict(load_toml(os.path.join(root, "scenarios", "segments.toml"))["defaults"])
    return Road(name, lap, k, lambda s: (-wr(s) + margin, wl(s) - margin), settings)


def oval_road(root, margin):
    """scenarios/oval.toml: the exact piecewise-constant curvature (right-continuous), the
    constant lane bounds taken as the edges, its [bounds] and [options]."""
    t = load_toml(os.path.join(root, "scenarios", "oval.toml"))
    lap = float(t["geometry"]["lap_length_m"])
    pieces = np.array(t["track"]["kappa_pieces"], dtype=float)

    def kappa_at(s):
        idx = np.searchsorted(pieces[:, 0], np.mod(s, lap), side="right") - 1
        return pieces[np.clip(idx, 0, len(pieces) - 1), 1]

    lo, hi = t["track"]["e_min_m"] + margin, t["track"]["e_max_m"] - margin
    settings = dict(t["bounds"])
    settings["enforce_tire_saturation"] = t["options"]["enforce_tire_saturation"]
    settings["steering_slew_weight"] = t["options"]["steering_slew_weight"]
    return Road("oval", lap, kappa_at, lambda s: (np.full_like(s, lo), np.full_like(s, hi)), settings)


def speed_guess(p, road, kappa, ds):
    """Quasi-steady speed profile at the nodes (module docstring)."""
    g_lat = GUESS_LAT * p.mu * p.g
    v = np.minimum(road.v_max, np.sqrt(g_lat / np.maximum(np.abs(kappa), 1e-9)))
    v = np.maximum(v, road.v_min)
    # Drive: rear axle friction at the static rear load (and the torque limit); brake: 0.8 mu g.
    a_acc = min(p.u_hi[1] / p.r_w, p.mu * p.fz_r) / p.m * 0.9
    a_brk = 0.8 * p.mu * p.g
    n = len(v)
    for _ in range(2):
        for k in range(1, 2 * n):
            i, j = k % n, (k - 1) % n
            v[i] = min(v[i], math.sqrt(v[j] ** 2 + 2 * a_acc * ds))
        for k in range(2 * n - 2, -1, -1):
            i, j = k % n, (k + 1) % n
            v[i] = min(v[i], math.sqrt(v[j] ** 2 + 2 * a_brk * ds))
    return v


def initial_guess(p, road, n, ds, kappa):
    """Scaled (X, U) guesses of shape (NX, n+1), (NU, n) from the quasi-steady profile."""
    v = speed_guess(p, road, kappa[:n], ds)
    v = np.append(v, v[0])
    ax = (np.roll(v, -1)[:n] ** 2 - v[:n] ** 2) / (2 * ds)  # on interval k
    ax = np.append(ax, ax[0])
    t = np.concatenate([[0.0], np.cumsum(2 * ds / (v[:-1] + v[1:]))])
    x = np.zeros((NX, n + 1))
    x[R], x[V], x[VWR] = v * kappa, v, v
    x[DFZ] = p.m * ax * p.h_cg / p.l
    x[S], x[T] = ds * np.arange(n + 1), t
    u = np.zeros((NU, n))
    u[0] = np.clip(p.l * kappa[:n], p.u_lo[0], p.u_hi[0])
    fx = p.m * ax[:n]
    front = p.b / p.l  # static front share of a braking force
    u[1] = np.where(fx > 0, fx * p.r_w, fx * (1 - front) * p.r_w)
    u[2] = np.where(fx > 0, 0.0, fx * front * p.r_w)
    for j in range(NU):
        u[j] = np.clip(u[j], p.u_lo[j], p.u_hi[j])
    return x / np.array(X_NOMINAL)[:, None], u / np.array(U_NOMINAL)[:, None]


def stage_functions(p, integrator):
    """Scaled defect, saturation and friction of one interval as CasADi Functions."""
    zx, zy, zu = ca.SX.sym("x", NX), ca.SX.sym("y", NX), ca.SX.sym("u", NU)
    kx, ky, ds = ca.SX.sym("kx"), ca.SX.sym("ky"), ca.SX.sym("ds")
    xn = ca.DM(X_NOMINAL)
    phys_u = [zu[j] * U_NOMINAL[j] for j in range(NU)]

    def f(z, kap):
        return cc.spatial(p, [z[i] * X_NOMINAL[i] for i in range(NX)], phys_u, kap) / xn

    if integrator == "ie":
        defect = zy - zx - ds * f(zy, ky)
    else:
        defect = zy - zx - ds / 2 * (f(zx, kx) + f(zy, ky))
    defect_fn = ca.Function("defect", [zx, zu, zy, kx, ky, ds], [defect])
    sat = cc.tires(p, [zx[i] * X_NOMINAL[i] for i in range(NX)], phys_u)[4] / cc.SATURATION_SCALE_FREE
    sat_fn = ca.Function("sat", [zx, zu], [sat])
    fric = (zu[2] * U_NOMINAL[2] / p.r_w + p.mu * (p.fz_f - zx[DFZ] * X_NOMINAL[DFZ])) / cc.FRICTION_SCALE
    fric_fn = ca.Function("fric", [zx, zu], [fric])
    return defect_fn, sat_fn, fric_fn


class LapNlp:
    """The periodic lap as one nlpsol problem: w = [vec(X); vec(U)], X of shape (NX, N+1)
    (column N is the lap's end, equal to column 0 but for s and t), U of shape (NU, N).
    `periodic=False` gives the planner's open window instead (no x_N = x_0 rows, rate and
    slew rows for k = 1..N-1); `fix_dpsi0` adds its dpsi_0 = 0."""

    def __init__(self, p, road, n, integrator, slew, periodic=True, fix_dpsi0=False):
        self.p, self.road, self.n = p, road, n
        self.periodic, self.fix_dpsi0 = periodic, fix_dpsi0
        self.ds = road.lap / n
        self.s_nodes = self.ds * np.arange(n + 1)
        self.kappa = road.kappa_at(self.s_nodes)
        self.e_lo, self.e_hi = road.e_at(self.s_nodes)
        if np.any(self.e_lo >= self.e_hi):
            sys.exit(f"{road.name}: the edge margin leaves no lane at s = {self.s_nodes[np.argmax(self.e_lo >= self.e_hi)]:.1f} m")
        X, U = ca.MX.sym("X", NX, n + 1), ca.MX.sym("U", NU, n)
        self.X, self.U = X, U
        defect_fn, sat_fn, fric_fn = stage_functions(p, integrator)
        kap = ca.DM(self.kappa).T
        defects = defect_fn.map(n)(X[:, :n], U, X[:, 1:], kap[:, :n], kap[:, 1:], self.ds)
        sat = sat_fn.map(n)(X[:, :n], U)
        fric0 = fric_fn.map(n)(X[:, :n], U)
        fric1 = fric_fn.map(n)(X[:, 1:], U)
        t_row = X[T, :]
        if periodic:  # every interval, u_{N-1} -> u_0 over t_N - t_{N-1}
            u_cur, u_prev = U, ca.horzcat(U[:, n - 1], U[:, : n - 1])
            dt = ca.horzcat(t_row[n] - t_row[n - 1], t_row[1:n] - t_row[: n - 1]) * X_NOMINAL[T]
        else:  # an open window, as the planner: k = 1..N-1
            u_cur, u_prev = U[:, 1:], U[:, : n - 1]
            dt = (t_row[1:n] - t_row[: n - 1]) * X_NOMINAL[T]
        m = u_cur.shape[1]
        du = [(u_cur[j, :] - u_prev[j, :]) * (U_NOMINAL[j] / p.rates[j]) for j in range(NU)]
        cyclic = [i for i in range(NX) if i not in (S, T)]  # the states with x_N = x_0
        self.groups = []  # (name, expression, lower, upper)
        sat_hi = p.eps_sat / cc.SATURATION_SCALE_FREE if road.saturation else ca.inf
        self.add("defect", ca.vec(defects), 0.0, 0.0)
        self.add("saturation", ca.vec(sat), -ca.inf, sat_hi)
        self.add("friction", ca.vertcat(ca.vec(fric0), ca.vec(fric1)), 0.0, ca.inf)
        for j in range(NU):
            self.add(f"rate{j}", ca.vertcat((du[j] - dt).T, (du[j] + dt).T), ca.vertcat(-ca.inf * ca.DM.ones(m), ca.DM.zeros(m)),
                     ca.vertcat(ca.DM.zeros(m), ca.inf * ca.DM.ones(m)))
        if self.periodic:
            self.add("periodic", X[cyclic, n] - X[cyclic, 0], 0.0, 0.0)
        slew_w = slew * (U_NOMINAL[0] / p.rates[0]) ** 2 / cc.OBJECTIVE_SCALE
        self.slew_expr = ca.sumsqr(du[0] * p.rates[0] / U_NOMINAL[0]) * slew_w * cc.OBJECTIVE_SCALE  # [s]
        obj = X[T, n] * X_NOMINAL[T] / cc.OBJECTIVE_SCALE + slew_w * ca.sumsqr(u_cur[0, :] - u_prev[0, :])
        self.w = ca.vertcat(ca.vec(X), ca.vec(U))
        self.g = ca.vertcat(*[grp[1] for grp in self.groups])
        self.obj = obj
        self.lbw, self.ubw = self.variable_bounds()

    def add(self, name, expr, lo, hi):
        m = expr.shape[0]
        lo = ca.DM(lo) if isinstance(lo, ca.DM) else ca.DM.ones(m) * lo
        hi = ca.DM(hi) if isinstance(hi, ca.DM) else ca.DM.ones(m) * hi
        self.groups.append((name, expr, lo, hi))

    def variable_bounds(self):
        p, n = self.p, self.n
        lx, ux = np.full((NX, n + 1), -np.inf), np.full((NX, n + 1), np.inf)
        lx[E], ux[E] = self.e_lo, self.e_hi
        lx[V], ux[V] = self.road.v_min, self.road.v_max
        lx[VWR] = p.v_wr_min
        lx[S, 0] = ux[S, 0] = lx[T, 0] = ux[T, 0] = 0.0
        if self.fix_dpsi0:
            lx[DPSI, 0] = ux[DPSI, 0] = 0.0
        xn = np.array(X_NOMINAL)[:, None]
        lu = np.repeat(np.array(p.u_lo)[:, None], n, axis=1) / np.array(U_NOMINAL)[:, None]
        uu = np.repeat(np.array(p.u_hi)[:, None], n, axis=1) / np.array(U_NOMINAL)[:, None]
        lo = np.concatenate([(lx / xn).flatten("F"), lu.flatten("F")])
        hi = np.concatenate([(ux / xn).flatten("F"), uu.flatten("F")])
        return lo, hi

    def solve(self, x0, u0, max_iter, print_level):
        solver = ca.nlpsol("lap", "ipopt", {"x": self.w, "f": self.obj, "g": self.g},
                           {"expand": True, "print_time": False,
                            "ipopt": {"tol": 1e-6, "constr_viol_tol": 1e-6, "max_iter": max_iter,
                                      "mu_strategy": "adaptive", "linear_solver": "mumps",
                                      "print_level": print_level, "sb": "yes"}})
        lbg = ca.vertcat(*[grp[2] for grp in self.groups])
        ubg = ca.vertcat(*[grp[3] for grp in self.groups])
        w0 = np.concatenate([x0.flatten("F"), u0.flatten("F")])
        w0 = np.clip(w0, self.lbw, self.ubw)
        t0 = time.perf_counter()
        sol = solver(x0=w0, lbx=self.lbw, ubx=self.ubw, lbg=lbg, ubg=ubg)
        wall = time.perf_counter() - t0
        stats = solver.stats()
        nx = NX * (self.n + 1)
        w = np.array(sol["x"]).ravel()
        xs = w[:nx].reshape((NX, self.n + 1), order="F") * np.array(X_NOMINAL)[:, None]
        us = w[nx:].reshape((NU, self.n), order="F") * np.array(U_NOMINAL)[:, None]
        g = np.array(sol["g"]).ravel()
        viol = {}
        at = 0
        for name, expr, lo, hi in self.groups:
            m = expr.shape[0]
            gg, lo_, hi_ = g[at:at + m], np.array(lo).ravel(), np.array(hi).ravel()
            viol[name] = float(np.max(np.maximum(0.0, np.maximum(lo_ - gg, gg - hi_)))) if m else 0.0
            at += m
        slew_s = float(ca.Function("slew", [self.w], [self.slew_expr])(sol["x"]))
        return {
            "status": stats["return_status"], "success": bool(stats["success"]),
            "iterations": int(stats["iter_count"]), "wall_s": wall, "x": xs, "u": us,
            "violation": viol, "slew_s": slew_s,
        }


def segment_road(root, name, margin):
    """A segment of scenarios/segments.toml as an open window of its track."""
    segs = load_toml(os.path.join(root, "scenarios", "segments.toml")).get("segments", [])
    seg = next((g for g in segs if g.get("name") == name), None)
    if seg is None:
        sys.exit(f"{root}/scenarios/segments.toml: no segment named {name!r}")
    base = track_road(root, seg["track"], margin)
    s0 = float(seg["s_start_m"])
    road = Road(name, float(seg["length_m"]), lambda s: base.kappa_at(s0 + s), lambda s: base.e_at(s0 + s),
                {"v_min_mps": base.v_min, "v_max_mps": base.v_max, "enforce_tire_saturation": base.saturation,
                 "steering_slew_weight": base.slew})
    return road


def make_road(args, name):
    if name == "oval":
        return oval_road(args.root, args.edge_margin_m)
    return track_road(args.root, name, args.edge_margin_m)


def solve_lap(args, p, name, window=False):
    """The periodic lap of a track, or (window) the open segment problem of the planner."""
    road = segment_road(args.root, name, args.edge_margin_m) if window else make_road(args, name)
    if args.steering_slew_weight is not None:
        road.slew = args.steering_slew_weight
    if args.v_max_mps is not None:
        road.v_max = args.v_max_mps
    n = max(4, round(road.lap / args.spacing))
    t0 = time.perf_counter()
    nlp = LapNlp(p, road, n, args.integrator, road.slew, periodic=not window, fix_dpsi0=window and not args.free_heading)
    x0, u0 = initial_guess(p, road, n, nlp.ds, nlp.kappa)
    build_s = time.perf_counter() - t0
    res = nlp.solve(x0, u0, args.max_iter, args.print_level)
    x = res["x"]
    periodic = [i for i in range(NX) if i not in (S, T)]
    res.update({
        "name": name, "road": road, "n": n, "ds": nlp.ds, "build_s": build_s,
        "lap_time_s": float(x[T, n]), "guess_lap_time_s": float(x0[T, n] * X_NOMINAL[T]),
        "max_abs_beta_rad": float(np.max(np.abs(x[BETA]))),
        "periodic_residual": float(np.max(np.abs(x[periodic, n] - x[periodic, 0]))) if not window else float("nan"),
        "v_min_mps": float(np.min(x[V])), "v_max_mps": float(np.max(x[V])),
        "lane_slack_m": float(np.min(np.minimum(x[E] - nlp.e_lo, nlp.e_hi - x[E]))),
        "s": nlp.s_nodes,
    })
    return res


def script_version():
    """SCRIPT_VERSION, the commit of HEAD and whether this script differs from it."""
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        head = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=here, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", os.path.basename(__file__), "casadi_compare.py"],
                               cwd=here, capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return SCRIPT_VERSION, "unknown"
    return SCRIPT_VERSION, head + ("-dirty" if dirty else "")


def write_atomic(path, text):
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


HEADER = """\
# Minimum lap times of the planner's car (config/vehicles/lc500.toml) on each shipped closed
# track: the reference a closed-loop lap is compared with. Written by
# bench/external/lap_reference.py, an independent CasADi + IPOPT (MUMPS) whole-lap solve:
# periodic lap (x_N = x_0 except s and t), lane = edges shrunk by edge_margin_m, the planner's
# model, path constraints and steering-slew term, v bounds of scenarios/segments.toml
# [defaults] (tracks) or scenarios/oval.toml (oval; its e_min_m/e_max_m taken as the edges).
# One entry per (track, edge margin). docs/lap-reference.md explains method and checks.
# Regenerate (offline, needs the venv of bench/external/requirements.txt), from the repo root:
#   .venv/bin/python bench/external/lap_reference.py --tracks Austin,Budapest,Montreal,Silverstone,Spa,oval
#   .venv/bin/python bench/external/lap_reference.py --tracks oval --edge-margin-m 0
# lap_time_s is t_N (the slew term is not included; slew_term_s is its value).
# solve_s is wall time on the machine that wrote the entry, for orientation only.
"""

PLANT_HEADER = """\
# Minimum lap times of the tracker plant's car under the mismatch file {mismatch} (its
# [vehicle] changes applied to config/vehicles/lc500.toml as ipc::mismatch::Mismatch::apply
# does): the reference of a closed-loop lap driven with that mismatch, since it is the car
# the loop drives. Written by bench/external/lap_reference.py --mismatch, with the method of
# lap_times.toml (docs/lap-reference.md, "The plant's car"). Regenerate from the repo root:
#   .venv/bin/python bench/external/lap_reference.py --mismatch default --tracks Austin,Budapest,Montreal,Silverstone,Spa,oval
# lap_time_s is t_N (the slew term is not included; slew_term_s is its value).
# solve_s is wall time on the machine that wrote the entry, for orientation only.
"""

FIELDS = ["name", "lap_time_s", "lap_length_m", "edge_margin_m", "node_spacing_m", "n_nodes", "integrator",
          "steering_slew_weight", "slew_term_s", "status", "iterations", "max_abs_beta_rad", "v_min_mps",
          "v_max_mps", "periodic_residual", "max_violation", "solve_s", "script_version", "script_commit",
          "speed_csv"]


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    return '"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"'


def entry_of(res, args):
    version, commit = script_version()
    return {
        "name": res["name"], "lap_time_s": round(res["lap_time_s"], 4), "lap_length_m": res["road"].lap,
        "edge_margin_m": args.edge_margin_m, "node_spacing_m": round(res["ds"], 4), "n_nodes": res["n"],
        "integrator": args.integrator, "steering_slew_weight": float(res["road"].slew),
        "slew_term_s": round(res["slew_s"], 5), "status": res["status"], "iterations": res["iterations"],
        "max_abs_beta_rad": round(res["max_abs_beta_rad"], 4), "v_min_mps": round(res["v_min_mps"], 3),
        "v_max_mps": round(res["v_max_mps"], 3), "periodic_residual": float(f"{res['periodic_residual']:.2e}"),
        "max_violation": float(f"{max(res['violation'].values()):.2e}"), "solve_s": round(res["wall_s"], 1),
        "script_version": version, "script_commit": commit, "speed_csv": speed_csv_name(res, args),
    }


def speed_csv_name(res, args):
    suffix = "" if args.edge_margin_m == 1.0 else f"_margin{args.edge_margin_m:g}"
    return f"{res['name']}{suffix}{plant_suffix(args)}_lap_speed.csv"


def plant_suffix(args):
    """'' for the planner's car, '_plant_<stem>' for a mismatch file's plant car."""
    if args.mismatch is None:
        return ""
    return "_plant_" + os.path.splitext(os.path.basename(mismatch_path(args.mismatch)))[0]


def mismatch_path(name):
    return "config/mismatch/default.toml" if name == "default" else name


def times_file(args):
    """lap_times.toml, or lap_times_plant_<stem>.toml for a mismatch file's plant car."""
    return os.path.join(args.out, f"lap_times{plant_suffix(args)}.toml")


def write_results(res, args):
    """Merges the entry into lap_times.toml (under a lock) and writes the speed CSV."""
    os.makedirs(args.out, exist_ok=True)
    x, s, n = res["x"], res["s"], res["n"]
    step = max(1, round(CSV_STEP_M / res["ds"]))
    idx = list(range(0, n, step)) + [n]
    lines = ["s_m,v_mps,e_m,t_s"] + [f"{s[k]:.3f},{x[V, k]:.4f},{x[E, k]:.4f},{x[T, k]:.4f}" for k in idx]
    write_atomic(os.path.join(args.out, speed_csv_name(res, args)), "\n".join(lines) + "\n")
    path = times_file(args)
    with open(path + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        entries = load_toml(path).get("tracks", []) if os.path.exists(path) else []
        new = entry_of(res, args)
        entries = [e for e in entries if (e["name"], e["edge_margin_m"]) != (new["name"], new["edge_margin_m"])]
        entries.append(new)
        order = {name: i for i, name in enumerate(SHIPPED)}
        entries.sort(key=lambda e: (order.get(e["name"], len(order)), e["name"], -e["edge_margin_m"]))
        body = [HEADER if args.mismatch is None else PLANT_HEADER.format(mismatch=mismatch_path(args.mismatch))]
        for e in entries:
            body.append("\n[[tracks]]\n" + "".join(f"{k} = {toml_value(e[k])}\n" for k in FIELDS if k in e))
        write_atomic(path, "".join(body))
    os.remove(path + ".lock")


def report(res):
    v = res["violation"]
    print(f"{res['name']:12} N={res['n']:5d} ds={res['ds']:.3f} {res['status']:22} its={res['iterations']:4d} "
          f"lap={res['lap_time_s']:9.4f} s (guess {res['guess_lap_time_s']:.2f}) slew={res['slew_s']:.5f} "
          f"|beta|max={res['max_abs_beta_rad']:.4f} V=[{res['v_min_mps']:.2f},{res['v_max_mps']:.2f}] "
          f"lane_slack={res['lane_slack_m']:.3f} periodic={res['periodic_residual']:.1e} "
          f"viol={max(v.values()):.1e} build={res['build_s']:.1f}s solve={res['wall_s']:.1f}s", flush=True)


def check(p):
    """A coarse oval lap (5.2 m spacing) must solve, be periodic and feasible, and have a
    lap time between a point-mass bound and the quasi-steady guess's."""
    args = parse_args(["--tracks", "oval", "--spacing", "5.2"])
    res = solve_lap(args, p, "oval")
    report(res)
    # A closed curve around the convex inner lane edge is at least as long as that edge
    # (2 straights + a circle of radius 25 m - lane half-width); at most v_max: a valid,
    # loose lower bound. The upper one is plausibility: 1.1 x the quasi-steady guess.
    road = res["road"]
    inner = 2 * 50.0 + 2 * math.pi * (25.0 - road.e_at(np.zeros(1))[1][0])
    bound = inner / road.v_max
    problems = []
    if not res["success"]:
        problems.append(f"status {res['status']}")
    if res["periodic_residual"] > 1e-6:
        problems.append(f"periodic residual {res['periodic_residual']:.1e}")
    if max(res["violation"].values()) > 1e-5:
        problems.append(f"constraint violation {res['violation']}")
    if not (bound < res["lap_time_s"] < res["guess_lap_time_s"] * 1.1):
        problems.append(f"lap time {res['lap_time_s']:.3f} s outside ({bound:.2f}, 1.1 x guess)")
    if problems:
        sys.exit("check FAILED: " + "; ".join(problems))
    print("check passed")


def compare_segments(args):
    """The written Austin lap profile over each segment window, next to the segment's own
    minimum time (free entry and exit speed, dpsi_0 = 0). Where the lap enters a window
    with dpsi ~ 0 it is a feasible point of the segment problem (up to the transcription
    and the slew term), so its window time can only be longer; where it enters at an angle
    it is outside the segment's feasible set. dpsi at the entry is recovered from the
    written e(s): de/ds = tan(dpsi) (1 - kappa e)."""
    segs = load_toml(os.path.join(args.root, "scenarios", "segments.toml"))["segments"]
    with open(os.path.join(args.out, "segments_ie_ipopt.csv"), newline="") as f:
        ref = {r["segment"]: float(r["t_N"]) for r in csv.DictReader(f)}
    with open(os.path.join(args.out, "Austin_lap_speed.csv"), newline="") as f:
        lap = np.array([[float(r["s_m"]), float(r["v_mps"]), float(r["e_m"]), float(r["t_s"])]
                        for r in csv.DictReader(f)])
    road = track_road(args.root, "Austin", 0.0)
    print(f"{'segment':8} {'s0 [m]':>7} {'lap window [s]':>15} {'segment t_N [s]':>16} {'diff':>7} "
          f"{'V in':>6} {'V out':>6} {'dpsi in':>8}")
    for seg in segs:
        if seg.get("track", "Austin") != "Austin":
            continue
        s0, s1 = seg["s_start_m"], seg["s_start_m"] + seg["length_m"]
        t0, t1 = np.interp([s0, s1], lap[:, 0], lap[:, 3])
        v0, v1 = np.interp([s0, s1], lap[:, 0], lap[:, 1])
        e0, de = np.interp(s0, lap[:, 0], lap[:, 2]), np.interp(s0, lap[:, 0], np.gradient(lap[:, 2], lap[:, 0]))
        dpsi0 = math.atan(de / (1 - road.kappa_at(np.array([s0]))[0] * e0))
        tn = ref.get(seg["name"], float("nan"))
        print(f"{seg['name']:8} {s0:7.0f} {t1 - t0:15.4f} {tn:16.4f} {(t1 - t0) / tn - 1:+7.2%} "
              f"{v0:6.2f} {v1:6.2f} {dpsi0:+8.3f}")


def solve_segments(args, p):
    """Open-window solves of segments, printed next to the reference minimum."""
    with open(os.path.join(args.out, "segments_ie_ipopt.csv"), newline="") as f:
        ref = {r["segment"]: float(r["t_N"]) for r in csv.DictReader(f)}
    for name in [t.strip() for t in args.segments.split(",") if t.strip()]:
        res = solve_lap(args, p, name, window=True)
        report(res)
        tn = ref.get(name, float("nan"))
        print(f"{name}: t_N {res['lap_time_s']:.4f} s, dpsi_0 {res['x'][DPSI, 0]:+.3f} rad; "
              f"segments_ie_ipopt.csv {tn:.4f} s ({res['lap_time_s'] / tn - 1:+.2%})", flush=True)


def apply_mismatch(p, path):
    """The plant's car of a mismatch file (ipc/src/mismatch.rs `Mismatch::apply`): mu, m,
    I_z, C_f and C_r changed by the file's [vehicle] relative values, the nominal axle loads
    following the mass. The actuator lag, delay and noise act on the controls and the
    measurement, not on the car's limits, and are left out."""
    with open(mismatch_path(path), "rb") as f:
        v = tomllib.load(f)["vehicle"]
    p.mu *= 1.0 + v["friction"]
    p.m *= 1.0 + v["mass"]
    p.i_z *= 1.0 + v["yaw_inertia"]
    p.c_f *= 1.0 + v["cornering_stiffness"]
    p.c_r *= 1.0 + v["cornering_stiffness"]
    p.fz_f = p.m * p.g * p.b / p.l
    p.fz_r = p.m * p.g * p.a / p.l


def main():
    args = parse_args()
    if args.compare_segments:
        compare_segments(args)
        return
    p = cc.Vehicle(args.vehicle)
    # The planner's grip scale: the friction and the brake torques derived from it
    # (VehicleParams::scale_grip).
    p.mu *= args.friction_scale
    p.u_lo[1] *= args.friction_scale
    p.u_lo[2] *= args.friction_scale
    if args.mismatch is not None:
        apply_mismatch(p, args.mismatch)
    if args.friction_scale != 1.0 or args.v_max_mps is not None:
        # The written references hold the car's own limits; a run with the planner's is
        # printed only. A plant's car goes to its own file (times_file).
        args.no_write = True
    if args.check:
        check(p)
        return
    if args.segments:
        solve_segments(args, p)
        return
    for name in [t.strip() for t in args.tracks.split(",") if t.strip()]:
        res = solve_lap(args, p, name)
        report(res)
        if not args.no_write:
            write_results(res, args)


if __name__ == "__main__":
    main()
