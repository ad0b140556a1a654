#!/usr/bin/env python3
"""The planner's OCP solved by IPOPT (MUMPS) and FATROP through CasADi, timed next to
`trajopt solve` on the same machine.

Same problem as the planner (implicit Euler, N = 100, scaled as in
planner/src/ocp/scaling.rs, saturation, friction and rate rows of
planner/src/ocp/path_constraints.rs, the steering-slew objective), same equilibrium guess,
tolerance 1e-6. The vehicle is read from the vehicle TOML; the road (kappa, e_min, e_max at
the nodes, to the 6-8 decimals of trajopt's CSV) and the guess come from `trajopt` itself.
Two differences in form, none in the feasible set: IPOPT gets the variable bounds as bounds
(`detect_simple_bounds`; Opti writes them as rows), and the six never-binding envelope rows
of the free initial state (|r_0| <= 10 rad/s etc., which the Rust NLP keeps for its KKT
structure) are left out.

FATROP takes only explicit dynamics x_{k+1} = F(x_k, u_k) and constraints within a stage:
implicit Euler is lifted (x_{k+1} becomes 9 extra controls y_k with the defect as a path
equality), and the rate rows and slew term get the previous control and time as 4 extra
states (nx = 13, nu = 12). That is what a FATROP user must write for this OCP.

Derivatives are CasADi's exact ones, JIT-compiled with `gcc -O3 -march=native` (the
fastest CasADi offers; `--no-jit` uses its virtual machine). The JIT compile takes a few
minutes per solver. Timed: the solver Function called K times (Opti's Python overhead is
outside), median. That call includes what each solve of these solvers pays anyway (IPOPT
builds its problem and MUMPS its symbolic analysis per call); trajopt's `solve_ms` excludes
its one-time setup, as the planner runs it. `evaluation_ms`: trajopt's evaluation phase
(constraint values and derivatives, median); for CasADi the Jacobian (with g), Hessian
and gradient calls of the last timed solve.

Setup (not needed by CI): python3 -m venv .venv && .venv/bin/pip install -r
bench/external/requirements.txt; cargo build --release -p planner --bin trajopt. Then:
    .venv/bin/python bench/external/casadi_compare.py [--cases oval,S01,S02] [--repeat 15]

The road and bounds are parameters of one NLP per solver, so each solver compiles once for
all the cases.
"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib

# One thread for every library (MUMPS's BLAS too), as trajopt's default.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402

# planner/src/ocp/scaling.rs
X_NOMINAL = [1.0, 10.0, 0.1, 10.0, 1000.0, 1.0, 0.1, 100.0, 10.0]
U_NOMINAL = [0.1, 1000.0, 1000.0]
OBJECTIVE_SCALE, FRICTION_SCALE, SATURATION_SCALE_FREE = 0.1, 1000.0, 3.0
NX, NU = 9, 3
R, V, BETA, VWR, DFZ, E, DPSI, S, T = range(NX)


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trajopt", default="target/release/trajopt")
    ap.add_argument("--vehicle", default="config/vehicles/lc500.toml")
    ap.add_argument("--cases", default="oval", help="oval and/or segment names, comma-separated")
    ap.add_argument("--segments-file", default="config/scenarios/segments.toml")
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--solvers", default="ipopt,fatrop")
    ap.add_argument("--no-jit", action="store_true")
    ap.add_argument("--steering-slew-weight", default=None,
                    help="passed to trajopt solve (0: the paper's pure minimum time)")
    ap.add_argument("--mu-strategy", default="monotone", choices=["monotone", "adaptive"],
                    help="IPOPT's barrier rule (the paper's Table III: adaptive)")
    ap.add_argument("--count-factorizations", action="store_true",
                    help="IPOPT: one more (untimed) solve per case with a detailed log, "
                         "counting MUMPS factorizations in all and per iteration")
    return ap.parse_args()


class Vehicle:
    """config/vehicles/lc500.toml, as planner/src/model/params.rs reads it."""

    def __init__(self, path):
        with open(path, "rb") as f:
            t = tomllib.load(f)
        c, w, ti, lt, lim, mo = (t[k] for k in ("chassis", "wheel", "tire", "load_transfer", "limits", "model"))
        self.m, self.l, self.a, self.b = c["m"], c["L"], c["a"], c["b"]
        self.h_cg, self.i_z, self.g = c["h_cg"], c["I_z"], c["g"]
        self.r_w, self.i_w = w["R_w"], w["I_w"]
        self.c_f, self.c_r, self.mu = ti["C_f"], ti["C_r"], ti["mu"]
        self.c_l = lt["c_L"]
        self.u_lo = [-lim["delta_max"], lim["T_comb_min"], lim["T_bf_min"]]
        self.u_hi = [lim["delta_max"], lim["T_comb_max"], lim["T_bf_max"]]
        self.v_wr_min = lim["V_wr_min"]
        self.rates = [lim["delta_rate_max"], lim["T_comb_rate_max"], lim["T_bf_rate_max"]]
        self.eps_sigma, self.eps_sat, self.floor = mo["eps_sigma"], mo["eps_sat"], mo["fmax_floor_frac"]
        self.fz_f = self.m * self.g * self.b / self.l
        self.fz_r = self.m * self.g * self.a / self.l


def tires(p, x, u):
    """Forces (F_xf, F_yf, F_xr, F_yr) and saturation values (planner/src/ocp/fast.rs)."""
    r, v, beta, v_wr, dfz = x[R], x[V], x[BETA], x[VWR], x[DFZ]
    sb, cb = ca.sin(beta), ca.cos(beta)
    vx = v * cb
    vy = v * sb
    tan_af_plus = (vy + r * p.a) / vx
    td = ca.tan(u[0])
    tan_af = (tan_af_plus - td) / (tan_af_plus * td + 1)
    tan_ar = (vy - r * p.b) / vx
    kappa_r = (v_wr - vx) / vx
    sig_f = ca.sqrt(tan_af**2 + p.eps_sigma**2)
    mu_fz = (-dfz + p.fz_f) * p.mu
    d = mu_fz**2 - (u[2] / p.r_w) ** 2
    q = (p.floor * p.mu * p.fz_f) ** 2
    fmax_f = ca.sqrt((d - q + ca.sqrt((d - q) ** 2 + q**2)) * 0.5 + q)

    def fiala(c, sig, fmax):
        xx = sig * c / (fmax * 3)
        return ca.if_else(xx < 1, fmax * (1 - (1 - xx) ** 3), fmax)

    fyf = -(fiala(p.c_f, sig_f, fmax_f) / sig_f * tan_af)
    sig_r = ca.sqrt(tan_ar**2 + kappa_r**2 + p.eps_sigma**2)
    fmax_r = (dfz + p.fz_r) * p.mu
    gr = fiala(p.c_r, sig_r, fmax_r) / sig_r
    sat = ca.vertcat(sig_f - fmax_f * 3 / p.c_f, sig_r - fmax_r * 3 / p.c_r)
    return u[2] / p.r_w, fyf, gr * kappa_r, -gr * tan_ar, sat


def spatial(p, x, u, kappa):
    """f = dx/ds of paper eq. (1) (planner/src/ocp/fast.rs `spatial_rows`)."""
    fxf, fyf, fxr, fyr, _ = tires(p, x, u)
    r, v, beta, dfz, e, dpsi = x[R], x[V], x[BETA], x[DFZ], x[E], x[DPSI]
    delta, t_comb = u[0], u[1]
    sd, cd, sb, cb = ca.sin(delta), ca.cos(delta), ca.sin(beta), ca.cos(beta)
    sdb, cdb = ca.sin(delta - beta), ca.cos(delta - beta)
    r_dot = ((fxf * sd + fyf * cd) * p.a - fyr * p.b) / p.i_z
    v_dot = (fxf * cdb - fyf * sdb + fxr * cb + fyr * sb) / p.m
    beta_dot = (fxf * sdb + fyf * cdb - fxr * sb + fyr * cb) / (v * p.m) - r
    vwr_dot = (t_comb - fxr * p.r_w) * (p.r_w / p.i_w)
    fx_net = fxr + fxf * cd - fyf * sd
    dfz_dot = -(dfz - fx_net * (p.h_cg / p.l)) * p.c_l
    sdot = v * ca.cos(dpsi) / (1 - e * kappa)
    dpsi_dot = beta_dot + r - sdot * kappa
    rows = [r_dot, v_dot, beta_dot, vwr_dot, dfz_dot, v * ca.sin(dpsi), dpsi_dot, sdot, 1]
    return ca.vertcat(*rows) / sdot


def scenario_of(args, case):
    """(scenario file, segment name or None) of a case."""
    return ("config/scenarios/oval.toml", None) if case == "oval" else (args.segments_file, case)


def trajopt_run(args, case, out_dir):
    """`trajopt solve --repeat K` of a case: the timing, and the files (the road at the
    nodes), which it writes once after the solves."""
    path, segment = scenario_of(args, case)
    base = [args.trajopt, "solve", "--vehicle", args.vehicle, "--scenario", path]
    if args.steering_slew_weight is not None:
        base += ["--steering-slew-weight", str(args.steering_slew_weight)]
    if segment:
        base += ["--segment", segment]
    def run(extra):
        done = subprocess.run(base + extra, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"{case}: {' '.join(base + extra)} failed:\n{done.stderr.strip()}")
        return json.loads(done.stdout)

    out = run(["--json", "--out-dir", out_dir, "--repeat", str(args.repeat)])
    csv_path = next(f for f in out["files"] if f.endswith(".csv"))
    with open(csv_path) as f:
        nodes = list(csv.DictReader(f))
    return out, nodes


def speed_bounds(path, segment):
    """(v_min, v_max) of a scenario ([bounds], or [defaults] and the segment's entry)."""
    with open(path, "rb") as f:
        t = tomllib.load(f)
    merged = dict(t.get("bounds", {}))
    merged.update(t.get("defaults", {}))
    for group in ("segments", "scenarios"):
        for entry in t.get(group, []):
            if entry.get("name") == segment:
                merged.update(entry)
                merged.update(entry.get("bounds", {}))
    mode = merged.get("initial_state", t.get("initial_state", {})).get("mode", "free")
    if mode != "free":
        sys.exit(f"{path}: only a free initial state is replicated here (got {mode!r})")
    return merged["v_min_mps"], merged["v_max_mps"]


class Case:
    """One scenario's data, as trajopt solved it."""

    def __init__(self, args, name):
        with tempfile.TemporaryDirectory() as out_dir:
            self.out, nodes = trajopt_run(args, name, out_dir)
        self.name = name
        self.n = len(nodes) - 1
        s = [float(r["s_grid"]) for r in nodes]
        self.ds = s[-1] / self.n  # the CSV rounds s_k to 6 decimals; s_N = length is exact
        self.kappa = [float(r["kappa"]) for r in nodes]
        self.e_lo = [float(r["e_min"]) / X_NOMINAL[E] for r in nodes]
        self.e_hi = [float(r["e_max"]) / X_NOMINAL[E] for r in nodes]
        self.v_min, self.v_max = speed_bounds(*scenario_of(args, name))
        self.slew_weight = self.out["steering_slew_weight"]
        self.saturation = self.out["tire_saturation"]
        eq = self.out["equilibrium"]
        self.x_eq, self.u_eq = eq["x"], eq["u"]

    def guess_x(self, k):
        """Equilibrium guess at node k (scaled): e = dpsi = 0, s_k = k ds, t_k = s_k / V."""
        x = list(self.x_eq)
        x[E] = x[DPSI] = 0.0
        x[S] = k * self.ds
        x[T] = x[S] / self.x_eq[V]
        return [x[i] / X_NOMINAL[i] for i in range(NX)]

    def guess_u(self):
        return [self.u_eq[j] / U_NOMINAL[j] for j in range(NU)]


class Nlp:
    """The OCP as an Opti problem whose road, speed bounds, ds and slew weight are
    parameters. `lifted` gives FATROP's form: state (x, u_prev, t_prev), control (u, y =
    x_{k+1}); else the planner's own x_0, u_0, ..., x_N."""

    def __init__(self, p, n, lifted):
        self.p, self.n, self.lifted = p, n, lifted
        opti = self.opti = ca.Opti()
        nxa, nua = (NX + NU + 1, NU + NX) if lifted else (NX, NU)
        self.xs, self.us = [], []
        for k in range(n + 1):  # stage order, as FATROP's structure detection needs
            self.xs.append(opti.variable(nxa))
            if k < n:
                self.us.append(opti.variable(nua))
        self.kappa = opti.parameter(n + 1)
        self.e_lo, self.e_hi = opti.parameter(n + 1), opti.parameter(n + 1)
        self.v_lo, self.v_hi = opti.parameter(), opti.parameter()
        self.ds, self.slew = opti.parameter(), opti.parameter()
        self.sat_hi = opti.parameter()  # eps_sat / scale, or +inf without saturation rows
        zx, zu, zy, kap, ds = (ca.SX.sym(n_, d) for n_, d in (("x", NX), ("u", NU), ("y", NX), ("k", 1), ("ds", 1)))
        phys_x = lambda z: [z[i] * X_NOMINAL[i] for i in range(NX)]
        phys_u = [zu[j] * U_NOMINAL[j] for j in range(NU)]
        f = spatial(p, phys_x(zy), phys_u, kap)
        defect = zy - zx - ds * ca.vertcat(*[f[i] / X_NOMINAL[i] for i in range(NX)])
        self.defect = ca.Function("defect", [zx, zu, zy, kap, ds], [defect])
        self.sat = ca.Function("sat", [zx, zu], [tires(p, phys_x(zx), phys_u)[4] / SATURATION_SCALE_FREE])
        x_of = lambda k: self.xs[k][:NX]
        u_of = lambda k: self.us[k][:NU]
        y_of = (lambda k: self.us[k][NU:]) if lifted else (lambda k: self.xs[k + 1])
        j = self.xs[n][T] * X_NOMINAL[T] / OBJECTIVE_SCALE
        for k in range(n):
            # Stage by stage, gap-closing row first (FATROP's structure detection).
            x, u, y = x_of(k), u_of(k), y_of(k)
            if lifted:
                opti.subject_to(self.xs[k + 1] == ca.vertcat(y, u, x[T]))
                if k == 0:
                    opti.subject_to(self.xs[0][NX:] == 0)
            self.node_bounds(x, k)
            opti.subject_to(self.defect(x, u, y, self.kappa[k + 1], self.ds) == 0)
            self.stage_rows(x, u, y)
            if k >= 1:
                u_prev, t_prev = (self.xs[k][NX:NX + NU], self.xs[k][NX + NU]) if lifted else (u_of(k - 1), x_of(k - 1)[T])
                j += self.rate_rows(u, u_prev, x[T], t_prev)
        self.node_bounds(x_of(n), n)
        opti.minimize(j)

    def node_bounds(self, x, k):
        """e, V and V_wr bounds; s_0 = t_0 = dpsi_0 = 0 (free initial state)."""
        opti = self.opti
        opti.subject_to(opti.bounded(self.e_lo[k], x[E], self.e_hi[k]))
        opti.subject_to(opti.bounded(self.v_lo, x[V], self.v_hi))
        opti.subject_to(x[VWR] >= self.p.v_wr_min / X_NOMINAL[VWR])
        if k == 0:
            for i in (S, T, DPSI):
                opti.subject_to(x[i] == 0)

    def friction(self, zx, zu):
        p = self.p
        return (zu[2] * U_NOMINAL[2] / p.r_w + p.mu * (p.fz_f - zx[DFZ] * X_NOMINAL[DFZ])) / FRICTION_SCALE

    def stage_rows(self, x, u, x_next):
        """Control box, saturation (R5) at (x_k, u_k), front friction (R9) at both nodes."""
        p, opti = self.p, self.opti
        lo = [p.u_lo[j] / U_NOMINAL[j] for j in range(NU)]
        hi = [p.u_hi[j] / U_NOMINAL[j] for j in range(NU)]
        opti.subject_to(opti.bounded(lo, u, hi))
        opti.subject_to(self.sat(x, u) <= self.sat_hi)
        opti.subject_to(self.friction(x, u) >= 0)
        opti.subject_to(self.friction(x_next, u) >= 0)

    def rate_rows(self, u, u_prev, t, t_prev):
        """Rate rows in the multiplied form; returns the slew term of the interval."""
        dt = (t - t_prev) * X_NOMINAL[T]
        for j in range(NU):
            du = (u[j] - u_prev[j]) * U_NOMINAL[j] / self.p.rates[j]
            self.opti.subject_to(du - dt <= 0)
            self.opti.subject_to(du + dt >= 0)
        return self.slew * (u[0] - u_prev[0]) ** 2

    def load(self, case):
        """Sets a case's parameters and the equilibrium guess."""
        opti = self.opti
        if case.n != self.n:
            sys.exit(f"{case.name}: N = {case.n}, the NLP was built for {self.n}")
        opti.set_value(self.kappa, case.kappa)
        opti.set_value(self.e_lo, case.e_lo)
        opti.set_value(self.e_hi, case.e_hi)
        opti.set_value(self.v_lo, case.v_min / X_NOMINAL[V])
        opti.set_value(self.v_hi, case.v_max / X_NOMINAL[V])
        opti.set_value(self.ds, case.ds)
        opti.set_value(self.sat_hi, self.p.eps_sat / SATURATION_SCALE_FREE if case.saturation else ca.inf)
        opti.set_value(self.slew, case.slew_weight * (U_NOMINAL[0] / self.p.rates[0]) ** 2 / OBJECTIVE_SCALE)
        for k in range(self.n + 1):
            gx = case.guess_x(k)
            if self.lifted:
                gx = gx + (case.guess_u() if k > 0 else [0.0] * NU) + [case.guess_x(k - 1)[T] if k > 0 else 0.0]
            opti.set_initial(self.xs[k], gx)
            if k < self.n:
                gu = case.guess_u() + (case.guess_x(k + 1) if self.lifted else [])
                opti.set_initial(self.us[k], gu)


def ipopt_options(args, log=None):
    """IPOPT's options; with `log`, a detailed log (print level 6) goes to that file."""
    opts = {"tol": 1e-6, "constr_viol_tol": 1e-6, "print_level": 0, "sb": "yes",
            "linear_solver": "mumps", "mu_strategy": args.mu_strategy}
    if log:
        opts.update({"output_file": log, "file_print_level": 6})
    return opts


def count_factorizations(nlp, case, args):
    """Factorizations of one IPOPT solve of `case`, from its detailed log: MUMPS numerical
    factorizations in all (the line MUMPS's statistics print after each one) and per
    search direction (IPOPT's "Number of trial factorizations performed": more than one
    when the inertia is corrected)."""
    with tempfile.TemporaryDirectory() as d:
        log = os.path.join(d, "ipopt.log")
        nlp.opti.solver("ipopt", {"expand": True, "print_time": False,
                                  "detect_simple_bounds": True}, ipopt_options(args, log))
        nlp.load(case)
        try:
            nlp.opti.solve()
        except RuntimeError:
            pass  # not converged: its log still counts
        with open(log) as f:
            text = f.read()
    per_direction = [int(line.rsplit(":", 1)[1]) for line in text.splitlines()
                     if line.startswith("Number of trial factorizations performed:")]
    hist = {}
    for k in per_direction:
        hist[str(k)] = hist.get(str(k), 0) + 1
    return {
        "factorizations": text.count("Number of doubles for MUMPS to hold factorization"),
        "directions": len(per_direction),
        "factorizations_per_direction_max": max(per_direction, default=0),
        "factorizations_per_direction": hist,
    }


def make_nlp(p, n, name, args):
    jit = {} if args.no_jit else {
        "jit": True, "compiler": "shell",
        "jit_options": {"flags": ["-O3", "-march=native"], "verbose": False},
    }
    if name not in ("ipopt", "fatrop"):
        sys.exit(f"unknown solver {name!r} (ipopt, fatrop)")
    nlp = Nlp(p, n, lifted=(name == "fatrop"))
    if name == "ipopt":
        nlp.opti.solver("ipopt", {"expand": True, "print_time": False, "detect_simple_bounds": True, **jit},
                        ipopt_options(args))
    else:
        nlp.opti.solver("fatrop", {"expand": True, "print_time": False, "structure_detection": "auto",
                                   "fatrop": {"tol": 1e-6, "constr_viol_tol": 1e-6, "print_level": 0},
                                   **jit})
    return nlp


def run_case(nlp, name, case, args):
    """Solves once through Opti (the first call JIT-compiles), then times the solver
    Function itself K times on the same arguments (guess, zero multipliers)."""
    nlp.load(case)
    opti, t_n = nlp.opti, nlp.xs[nlp.n][T]
    t0 = time.perf_counter()
    try:
        t_final = float(opti.solve().value(t_n)) * X_NOMINAL[T]
    except RuntimeError as err:
        try:  # solved but not converged: report the last iterate
            t_final = float(opti.debug.value(t_n)) * X_NOMINAL[T]
        except RuntimeError:
            sys.exit(f"{case.name}: {name} did not run: {err}")
    first_s = time.perf_counter() - t0
    solver, arg = opti.debug.casadi_solver, opti.debug.arg()
    ms = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        solver(**arg)
        ms.append((time.perf_counter() - t0) * 1e3)
    stats = solver.stats()
    its = stats.get("iter_count")
    status = str(stats.get("return_status"))
    if status == "0":  # some FATROP builds report a number
        status = str(stats.get("unified_return_status", status))
    eval_s = sum(stats.get(k, 0.0) for k in ("t_wall_nlp_hess_l", "t_wall_nlp_jac_g", "t_wall_nlp_grad_f"))
    med = statistics.median(ms)
    return {
        "case": case.name, "solver": name, "status": status, "iterations": its,
        "t_final": t_final, "solve_ms_median": med, "solve_ms_min": min(ms),
        "ms_per_iteration": med / its if its else float("nan"),
        "evaluation_ms": eval_s * 1e3, "hessian_ms": stats.get("t_wall_nlp_hess_l", 0.0) * 1e3,
        "first_solve_s": first_s,
    }


def trajopt_row(case):
    t = case.out
    return {
        "case": case.name, "solver": "trajopt", "status": t["status"], "iterations": t["iterations"],
        "t_final": t["t_final"], "solve_ms_median": t["solve_ms"], "solve_ms_min": min(t["solve_ms_all"]),
        "ms_per_iteration": t["solve_ms"] / t["iterations"] if t["iterations"] else float("nan"),
        "evaluation_ms": t["times_ms_median"]["evaluation"], "hessian_ms": None, "first_solve_s": None,
    }


def main():
    args = parse_args()
    p = Vehicle(args.vehicle)
    cases = [Case(args, name.strip()) for name in args.cases.split(",")]
    rows = [trajopt_row(c) for c in cases]
    for name in args.solvers.split(","):
        nlp = make_nlp(p, cases[0].n, name, args)
        rows += [run_case(nlp, name, c, args) for c in cases]
        if name == "ipopt" and args.count_factorizations:
            counts = {c.name: count_factorizations(nlp, c, args) for c in cases}
            for r in rows:
                if r["solver"] == "ipopt":
                    r.update(counts[r["case"]])
    rows.sort(key=lambda r: [c.name for c in cases].index(r["case"]))
    print(f"median of {args.repeat} solves each; CasADi derivatives "
          f"{'interpreted' if args.no_jit else 'JIT-compiled (gcc -O3 -march=native)'}", file=sys.stderr)
    print(f"{'case':6} {'solver':8} {'status':18} {'its':>4} {'t_N [s]':>9} {'median ms':>10} "
          f"{'ms/it':>7} {'eval ms':>9}", file=sys.stderr)
    for r in rows:
        print(f"{r['case']:6} {r['solver']:8} {r['status'][:18]:18} {r['iterations'] or 0:>4} {r['t_final']:9.4f} "
              f"{r['solve_ms_median']:10.2f} {r['ms_per_iteration']:7.3f} {r['evaluation_ms']:9.2f}",
              file=sys.stderr)
    print(json.dumps({"repeat": args.repeat, "jit": not args.no_jit, "results": rows}, indent=1))


if __name__ == "__main__":
    main()
