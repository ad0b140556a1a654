#!/usr/bin/env python3
"""Footprint version of the "critical" collision-avoidance OCP
(config/scenarios/collision_avoidance.toml), saturation off.

Model, scaling and rows: bench/external/casadi_compare.py (imported, not
copied): implicit Euler x_{k+1} - x_k - ds f(x_{k+1}, u_k) = 0, kappa = 0, control box,
front friction (R9) at (x_k,u_k) and (x_{k+1},u_k), V_wr >= 0 (R10), rate rows k >= 1
(multiplied form), V in [5, 40], road CG bounds [-3.5, 3.5], objective t_N, free end.
Initial state fixed: straight cruise at V0 (25 m/s), e = beta = r = dpsi = dFz = 0, V_wr = V0.

Obstacle boxes as ipc/src/road/footprint.rs::obstacle_boxes (h = 1 m):
  O1: s in [12.5, 17.5], e in [-4.5, 0.0]   (override e_min = 1.0   -> box up to 1.0 - 1)
  O2: s in [35.0, 40.0], e in [-0.25, 4.5]  (override e_max = -1.25 -> box from -1.25 + 1)
Footprint: 4.77 m x 1.92 m rectangle centred on the CG, heading psi = dpsi - beta.

Obstacle formulations (--mode):
  cg   : the scenario's CG bounds at nodes with s_k in the closed interval (reference).
  sep  : EXACT disjointness at the nodes: per node near an obstacle a separating line
         n = (cos th, sin th), offset c (extra variables): n.p_i >= c + margin for the 4 car
         corners, n.q_j <= c for the 4 box corners (convex polygons are disjoint iff such a
         line exists).  Applied at every node whose CG s is within 2.6 m (> half-diagonal)
         of the box, plus optionally at --sub interpolated points per interval
         (linear interpolation of e, psi between nodes; s is exact = s_k + f ds).
  lat  : at nodes with CG s in the interval: all 4 corners on the passing side.
  nec  : relaxation: at nodes with CG s in the interval the body section through the CG
         (e -+ (W/2)/cos psi) on the passing side.  Necessary for the footprint at nodes.
"""
import argparse
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import casadi as ca  # noqa: E402
import casadi_compare as cc  # noqa: E402
from casadi_compare import X_NOMINAL as XN, U_NOMINAL as UN, NX, NU  # noqa: E402
from casadi_compare import R, V, BETA, VWR, DFZ, E, DPSI, S, T  # noqa: E402

VEH = os.path.join(HERE, "..", "..", "config", "vehicles", "lc500.toml")
LEN, WID, H = 4.77, 1.92, 1.0
HL, HW = LEN / 2, WID / 2
ROAD = (-3.5, 3.5)
OVERRIDES = [(12.5, 17.5, 1.0, 3.5), (35.0, 40.0, -3.5, -1.25)]  # critical
REACH = math.hypot(HL, HW) + 0.05


def boxes():
    """(s0, s1, e0, e1, side) per obstacle; side +1: pass left (car above), -1: right."""
    out = []
    for s0, s1, lo, hi in OVERRIDES:
        if lo > ROAD[0]:
            out.append((s0, s1, ROAD[0] - H, lo - H, +1))
        if hi < ROAD[1]:
            out.append((s0, s1, hi + H, ROAD[1] + H, -1))
    return out


BOXES = boxes()


def corners(s, e, psi, sin=math.sin, cos=math.cos):
    sn, cs = sin(psi), cos(psi)
    return [(s + a * cs - b * sn, e + a * sn + b * cs) for a, b in ((HL, HW), (-HL, HW), (-HL, -HW), (HL, -HW))]


# ---------------------------------------------------------------- clearance (port of footprint.rs)
def _proj(q, n):
    xs = [p[0] * n[0] + p[1] * n[1] for p in q]
    return min(xs), max(xs)


def clearance(a, b):
    least = math.inf
    for poly in (a, b):
        for i in range(4):
            ex, ey = poly[(i + 1) % 4][0] - poly[i][0], poly[(i + 1) % 4][1] - poly[i][1]
            ln = math.hypot(ex, ey)
            n = (-ey / ln, ex / ln)
            (alo, ahi), (blo, bhi) = _proj(a, n), _proj(b, n)
            least = min(least, min(ahi, bhi) - max(alo, blo))
    if least > 0:
        return -least
    d = math.inf
    for p, q in ((a, b), (b, a)):
        for v in p:
            for i in range(4):
                ax, ay = q[i]
                bx, by = q[(i + 1) % 4]
                abx, aby = bx - ax, by - ay
                t = max(0.0, min(1.0, ((v[0] - ax) * abx + (v[1] - ay) * aby) / (abx * abx + aby * aby)))
                d = min(d, math.hypot(v[0] - ax - t * abx, v[1] - ay - t * aby))
    return d


def box_quad(b):
    s0, s1, e0, e1, _ = b
    return [(s0, e0), (s1, e0), (s1, e1), (s0, e1)]


def min_clearance(traj, sub=1):
    """Min footprint clearance over nodes (sub = 1) or sub points per interval (linear
    interpolation of e and psi).  traj: list of dicts with s, e, psi."""
    best = (math.inf, None)
    for k in range(len(traj) - 1 if sub > 1 else len(traj)):
        for f in range(sub):
            w = f / sub
            a = traj[k]
            b = traj[k + 1] if sub > 1 else a
            s = a["s"] + w * (b["s"] - a["s"])
            e = a["e"] + w * (b["e"] - a["e"])
            psi = a["psi"] + w * (b["psi"] - a["psi"])
            car = corners(s, e, psi)
            for bx in BOXES:
                c = clearance(car, box_quad(bx))
                if c < best[0]:
                    best = (c, s)
    if sub > 1:  # last node
        a = traj[-1]
        for bx in BOXES:
            best = min(best, (clearance(corners(a["s"], a["e"], a["psi"]), box_quad(bx)), a["s"]))
    return best


# ---------------------------------------------------------------- OCP
class Ocp:
    def __init__(self, p, n, mode, length=125.0, v0=25.0, v0_free=False, margin=0.0, sub=1,
                 vwr_min=True, max_iter=3000, mu_strategy="adaptive", v0_max=25.0, maxclear=False):
        self.p, self.n, self.mode, self.ds = p, n, mode, length / n
        self.v0_free = v0_free
        self.v0_phys = v0
        opti = self.opti = ca.Opti()
        self.xs = [opti.variable(NX) for _ in range(n + 1)]
        self.us = [opti.variable(NU) for _ in range(n)]
        self.sep = []  # (k, frac, box index, th var, c var)
        zx, zu, zy = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("y", NX)
        phys_x = lambda z: [z[i] * XN[i] for i in range(NX)]
        f = cc.spatial(p, phys_x(zy), [zu[j] * UN[j] for j in range(NU)], 0.0)
        defect = zy - zx - self.ds * ca.vertcat(*[f[i] / XN[i] for i in range(NX)])
        dfun = ca.Function("defect", [zx, zu, zy], [defect]).expand()
        lo = [p.u_lo[j] / UN[j] for j in range(NU)]
        hi = [p.u_hi[j] / UN[j] for j in range(NU)]
        nl = cc.Nlp.__new__(cc.Nlp)
        nl.p = p
        fr = nl.friction
        x0 = self.xs[0]
        self.maxclear = maxclear
        if maxclear:  # margin becomes a variable to maximise (min clearance at the nodes)
            self.mvar = opti.variable()
            opti.subject_to(self.mvar <= 2.0)
            opti.set_initial(self.mvar, -1.0)
            margin = self.mvar
        if v0_free:
            self.v0 = opti.variable()
            opti.subject_to(opti.bounded(5.0 / XN[V], self.v0, v0_max / XN[V]))
            opti.set_initial(self.v0, v0 / XN[V])
            v0e = self.v0
        else:
            v0e = v0 / XN[V]
        fixed = {R: 0, V: v0e, BETA: 0, VWR: v0e, DFZ: 0, E: 0, DPSI: 0, S: 0, T: 0}
        for i, val in fixed.items():
            opti.subject_to(x0[i] == val)
        for k in range(n + 1):
            x = self.xs[k]
            sk = k * self.ds
            elo, ehi = ROAD
            if mode == "cg":
                for s0, s1, olo, ohi in OVERRIDES:
                    if s0 - 1e-9 <= sk <= s1 + 1e-9:
                        elo, ehi = olo, ohi
            if k > 0:
                opti.subject_to(opti.bounded(elo / XN[E], x[E], ehi / XN[E]))
                opti.subject_to(opti.bounded(p.v_min_ / XN[V] if hasattr(p, "v_min_") else 5.0 / XN[V], x[V], 40.0 / XN[V]))
                if vwr_min:
                    opti.subject_to(x[VWR] >= p.v_wr_min / XN[VWR])
            if k < n:
                u, y = self.us[k], self.xs[k + 1]
                opti.subject_to(dfun(x, u, y) == 0)
                opti.subject_to(opti.bounded(lo, u, hi))
                opti.subject_to(fr(x, u) >= 0)
                opti.subject_to(fr(y, u) >= 0)
                if k >= 1:
                    dt = (x[T] - self.xs[k - 1][T]) * XN[T]
                    for j in range(NU):
                        du = (u[j] - self.us[k - 1][j]) * UN[j] / p.rates[j]
                        opti.subject_to(du - dt <= 0)
                        opti.subject_to(du + dt >= 0)
        # footprint rows
        if mode in ("sep", "lat", "nec"):
            for k in range(n + 1):
                subs = range(sub) if (mode == "sep" and k < n) else [0]
                for fsub in subs:
                    w = fsub / sub
                    sk = (k + w) * self.ds
                    xa = self.xs[k]
                    xb = self.xs[k + 1] if w > 0 else xa
                    e = (xa[E] * (1 - w) + xb[E] * w) * XN[E]
                    psi = ((xa[DPSI] - xa[BETA]) * (1 - w) + (xb[DPSI] - xb[BETA]) * w) * XN[DPSI]
                    for bi, bx in enumerate(BOXES):
                        s0, s1, e0, e1, side = bx
                        edge = e1 if side > 0 else e0
                        if mode == "sep":
                            if not (s0 - REACH <= sk <= s1 + REACH):
                                continue
                            th, c = opti.variable(), opti.variable()
                            self.sep.append((k, w, bi, th, c))
                            nvec = (ca.cos(th), ca.sin(th))
                            for (cs_, ce_) in corners(sk, e, psi, ca.sin, ca.cos):
                                opti.subject_to(nvec[0] * cs_ + nvec[1] * ce_ - c >= margin)
                            for (qs, qe) in box_quad(bx):
                                opti.subject_to(nvec[0] * qs + nvec[1] * qe - c <= 0)
                        else:
                            if not (s0 - 1e-9 <= sk <= s1 + 1e-9):
                                continue
                            if mode == "lat":
                                for (_, ce_) in corners(sk, e, psi, ca.sin, ca.cos):
                                    opti.subject_to(side * (ce_ - edge) >= margin)
                            else:
                                opti.subject_to(side * (e - edge) - HW / ca.cos(psi) >= margin)
        tn = self.xs[n][T] * XN[T]
        self.obj_v0 = v0_free
        if maxclear:
            opti.minimize(-self.mvar + 1e-4 * tn)
        else:
            opti.minimize(-self.v0 * XN[V] + 1e-3 * tn if v0_free else tn / cc.OBJECTIVE_SCALE)
        opti.solver("ipopt", {"expand": True, "print_time": False, "detect_simple_bounds": True},
                    {"tol": 1e-6, "constr_viol_tol": 1e-6, "print_level": 0, "sb": "yes",
                     "linear_solver": "mumps", "mu_strategy": mu_strategy, "max_iter": max_iter})

    # guesses ---------------------------------------------------------------
    def guess_equilibrium(self, v, eprof=None):
        for k in range(self.n + 1):
            sk = k * self.ds
            x = [0.0] * NX
            x[V], x[VWR] = v, v
            x[S], x[T] = sk, sk / max(v, 1e-3) if k else 0.0
            if eprof is not None and k > 0:
                x[E] = eprof(sk)
            if k == 0:
                x[V] = x[VWR] = getattr(self, "v0_phys", 25.0)
            self.opti.set_initial(self.xs[k], [x[i] / XN[i] for i in range(NX)])
            if k < self.n:
                self.opti.set_initial(self.us[k], [0.0] * NU)
        self._guess_sep()

    def guess_traj(self, X, U):
        """X: (n+1) x NX physical, U: n x NU physical, on this OCP's grid."""
        for k in range(self.n + 1):
            self.opti.set_initial(self.xs[k], [X[k][i] / XN[i] for i in range(NX)])
            if k < self.n:
                self.opti.set_initial(self.us[k], [U[k][j] / UN[j] for j in range(NU)])
        self._guess_sep()

    def _guess_sep(self):
        for k, w, bi, th, c in self.sep:
            s0, s1, e0, e1, side = BOXES[bi]
            sk = (k + w) * self.ds
            if sk < s0 - HL:
                th0, c0 = math.pi, -s0  # car behind the box: n = (-1, 0)
            elif sk > s1 + HL:
                th0, c0 = 0.0, s1
            else:
                th0, c0 = (math.pi / 2, e1) if side > 0 else (-math.pi / 2, -e0)
            self.opti.set_initial(th, th0)
            self.opti.set_initial(c, c0)

    def solve(self):
        try:
            sol = self.opti.solve()
            val = sol.value
        except RuntimeError:
            val = self.opti.debug.value
        st = self.opti.stats()
        X = [[float(v) * XN[i] for i, v in enumerate(ca.DM(val(self.xs[k])).full().ravel())] for k in range(self.n + 1)]
        U = [[float(v) * UN[j] for j, v in enumerate(ca.DM(val(self.us[k])).full().ravel())] for k in range(self.n)]
        res = {"status": st["return_status"], "iter": st["iter_count"], "X": X, "U": U,
               "t_N": X[-1][T], "peak_beta": max(abs(x[BETA]) for x in X),
               "V0": X[0][V]}
        if self.maxclear:
            res["margin"] = float(val(self.mvar))
        g = ca.DM(val(self.opti.g)).full().ravel()
        lbg = ca.DM(val(self.opti.lbg)).full().ravel()
        ubg = ca.DM(val(self.opti.ubg)).full().ravel()
        import numpy as np
        res["max_viol"] = float(max(np.max(np.maximum(lbg - g, 0)), np.max(np.maximum(g - ubg, 0))))
        traj = [{"s": x[S], "e": x[E], "psi": x[DPSI] - x[BETA]} for x in X]
        res["clear_nodes"] = min_clearance(traj, 1)
        res["clear_sub20"] = min_clearance(traj, 20)
        res["peak_body_heading"] = max(abs(t["psi"]) for t in traj)
        res["Vmin"] = min(x[V] for x in X[:40 * self.n // 100 + 1])
        return res


def resample(X, U, n_from, n_to):
    """Linear interpolation in s of a solution onto a finer grid (same length)."""
    out_x, out_u = [], []
    for k in range(n_to + 1):
        q = k * n_from / n_to
        i = min(int(q), n_from - 1)
        w = q - i
        out_x.append([X[i][m] * (1 - w) + X[i + 1][m] * w for m in range(NX)])
        if k < n_to:
            out_u.append(list(U[min(int(q), n_from - 1)]))
    return out_x, out_u


def summary(tag, r):
    return (f"{tag:42s} {r['status']:28s} it={r['iter']:4d} t_N={r['t_N']:.4f} "
            f"peak|beta|={r['peak_beta']:.3f} peak|psi|={r['peak_body_heading']:.3f} V0={r['V0']:.3f} "
            f"Vmin(s<50)={r['Vmin']:.2f} viol={r['max_viol']:.1e} "
            f"clear_nodes={r['clear_nodes'][0]:+.3f}@s={r['clear_nodes'][1]:.2f} "
            f"clear_sub={r['clear_sub20'][0]:+.3f}@s={r['clear_sub20'][1]:.2f}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--out", default="out/footprint_swerve.jsonl")
    ap.add_argument("--only", default="all")
    ap.add_argument("--what", default="fixed,maxv0")
    ap.add_argument("--max-iter", type=int, default=3000)
    args = ap.parse_args()
    p = cc.Vehicle(VEH)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    log = open(args.out, "a")

    def record(tag, r):
        line = summary(tag, r)
        print(line, flush=True)
        log.write(json.dumps({"tag": tag, **{k: v for k, v in r.items()}}) + "\n")
        log.flush()

    # 1. CG-only reference (validates the model against the scenario header)
    ref = Ocp(p, args.n, "cg")
    ref.guess_equilibrium(24.97)
    r_ref = ref.solve()
    record(f"cg N={args.n} eq-guess", r_ref)
    if args.only == "ref":
        return

    def eprof_lane(a1, a2):
        # smooth left-then-right swerve: +a1 around O1, -a2 around O2
        def f(s):
            up = 0.5 * (1 + math.tanh((s - 8.0) / 2.5))
            dn = 0.5 * (1 + math.tanh((s - 26.0) / 2.5))
            return a1 * up - (a1 + a2) * dn
        return f

    modes = args.only.split(",") if args.only not in ("all",) else ["sep", "lat", "nec"]
    for mode in modes:
        n = args.n
        sub = 1
        if mode.startswith("sep") and ":" in mode:
            sub = int(mode.split(":")[1])
        m = mode.split(":")[0]
        guesses = [("eq24.97", lambda o: o.guess_equilibrium(24.97)),
                   ("cg-ref", lambda o: o.guess_traj(*resample(r_ref["X"], r_ref["U"], 100, n)) if n != 100 else o.guess_traj(r_ref["X"], r_ref["U"])),
                   ("eq20", lambda o: o.guess_equilibrium(20.0)),
                   ("eq15", lambda o: o.guess_equilibrium(15.0)),
                   ("eq10", lambda o: o.guess_equilibrium(10.0)),
                   ("eq15+path", lambda o: o.guess_equilibrium(15.0, eprof_lane(2.0, 2.0))),
                   ("eq8+path", lambda o: o.guess_equilibrium(8.0, eprof_lane(2.0, 2.0)))]
        what = args.what.split(",")
        if "maxclear" in what:
            oc = Ocp(p, n, m, sub=sub, maxclear=True, max_iter=args.max_iter)
            for gname, g in guesses:
                g(oc)
                r = oc.solve()
                record(f"{mode} N={n} MAXCLEAR@25 guess={gname} margin={r['margin']:+.4f}", r)
        if "fixed" not in what:
            guesses_f = []
        else:
            guesses_f = guesses
        o = Ocp(p, n, m, sub=sub, max_iter=args.max_iter)
        best = None
        for gname, g in guesses_f:
            g(o)
            r = o.solve()
            record(f"{mode} N={n} guess={gname}", r)
            if r["status"] == "Solve_Succeeded" and (best is None or r["t_N"] < best["t_N"]):
                best = r
        # free initial speed: maximise V0 <= 25
        if "maxv0" not in what:
            continue
        of = Ocp(p, n, m, sub=sub, v0_free=True, max_iter=args.max_iter)
        for gname, g in guesses[:5]:
            g(of)
            r = of.solve()
            record(f"{mode} N={n} MAX-V0 guess={gname}", r)


if __name__ == "__main__":
    main()
