#!/usr/bin/python3
"""The depths' second-order term's expansion on a scalar least-squares toy (docs/studies/depth-noise.md, "What the
expansion still leaves out").

One pose coordinate x, one depth d, F nonlinear residuals r_f(x, d) with weights lam_f. At the
true x the profile score U = sum_f J_f(d^) lam_f r_f(d^), with d^ the exact minimizer over d, is
compared with its expansion U1 + A + B, where
  U1 = sum J lam P-perp r                      (first order)
  A  = delta * sum beta_f r_f                  (the pose Jacobians move with the depth)
  B  = 1/2 delta^2 g                           (the residual is curved in the depth)
and delta = -sum J_d lam r / h. With the header's beta (J') the error is O(eps^2); with
J~' = J' - b r'' / h it is O(eps^3) (the error falls 8x when eps halves), and only with +B, which
fixes the sign of the two terms' covariance. Run: /usr/bin/python3 scripts/second_order_score_check.py
"""
import numpy as np

rng = np.random.default_rng(3)
F = 5
p, q, k = rng.normal(size=F), rng.normal(size=F) + 1.5, rng.normal(size=F)
lam = rng.uniform(0.5, 2, F)
x0, d0 = 0.3, 0.8
STEP = 1e-5


def pred(x, d):
    return np.sin(p * x + q * d) + k * x * d * d + 0.3 * d**3 * q


def dx(fun):
    return lambda x, d, y: (fun(x + STEP, d, y) - fun(x - STEP, d, y)) / (2 * STEP)


def dd(fun):
    return lambda x, d, y: (fun(x, d + STEP, y) - fun(x, d - STEP, y)) / (2 * STEP)


def res(x, d, y):
    return pred(x, d) - y


J, Jd = dx(res), dd(res)
Jp, Jdd = dd(J), dd(Jd)


def dhat(x, y):
    d = d0
    for _ in range(50):
        d -= np.sum(Jd(x, d, y) * lam * res(x, d, y)) / np.sum(Jd(x, d, y) ** 2 * lam)
    return d


def errors(s, runs=200):
    out = {"header J', +B": [], "J~', +B": [], "J~', -B": []}
    for _ in range(runs):
        y = pred(x0, d0) + s * rng.normal(size=F)
        r, j, jd, jp, rdd = (f(x0, d0, y) for f in (res, J, Jd, Jp, Jdd))
        h, b = np.sum(lam * jd * jd), np.sum(j * lam * jd)
        delta = -np.sum(jd * lam * r) / h
        u1 = np.sum(j * lam * r) + b * delta
        al = lam * jd / h
        beta = lam * jp - np.sum(lam * jp * jd) * al
        a_header = delta * np.sum(beta * r)
        a_exact = delta * np.sum(lam * (jp - b * rdd / h) * (r + jd * delta))
        g = np.sum(j * lam * rdd) - b * np.sum(jd * lam * rdd) / h
        bterm = 0.5 * delta**2 * g
        dh = dhat(x0, y)
        exact = np.sum(J(x0, dh, y) * lam * res(x0, dh, y))
        out["header J', +B"].append(abs(exact - (u1 + a_header + bterm)))
        out["J~', +B"].append(abs(exact - (u1 + a_exact + bterm)))
        out["J~', -B"].append(abs(exact - (u1 + a_exact - bterm)))
    return {key: float(np.mean(v)) for key, v in out.items()}


if __name__ == "__main__":
    for s in (1e-2, 5e-3, 2.5e-3):
        print(f"eps {s:g}: " + ", ".join(f"{k} {v:.3g}" for k, v in errors(s).items()))
