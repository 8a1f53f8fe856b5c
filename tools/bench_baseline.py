"""Baseline for tools/bench.py: the chapter's loop written the straightforward way.

Not used by the course. It is what engine.py is measured against: 3-vectors, force via
np.linalg.norm and **, energy evaluated inside the loop at every step, rerun imported
up front, and one rr.log per step. Run as a script it does a whole run like engine.py.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import rerun as rr  # imported up front, as in the chapter's listing, even for --no-rerun


def build_system(name, rng):
    if name == "orbit":
        mu, m = 1.0, 1.0
        q0, v0 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0 + rng.uniform(-0.05, 0.05), 0.0])
        force = lambda q, v: -mu * m * q / (np.linalg.norm(q) ** 3)  # noqa: E731
        energy = lambda q, v: 0.5 * m * (v @ v) - mu * m / np.linalg.norm(q)  # noqa: E731
    elif name == "spring":
        k, m = 4.0, 1.0
        q0, v0 = np.array([1.0 + rng.uniform(-0.1, 0.1), 0.0, 0.0]), np.zeros(3)
        force = lambda q, v: -k * q  # noqa: E731
        energy = lambda q, v: 0.5 * m * (v @ v) + 0.5 * k * (q @ q)  # noqa: E731
    else:
        g, m = 9.81, 1.0
        q0, v0 = np.array([0.0, 0.0, 10.0]), np.array([3.0 + rng.uniform(-0.5, 0.5), 0.0, 0.0])
        force = lambda q, v: m * np.array([0.0, 0.0, -g])  # noqa: E731
        energy = lambda q, v: 0.5 * m * (v @ v) + m * g * q[2]  # noqa: E731
    return {"q0": q0, "v0": v0, "m": m, "force": force, "energy": energy}


def euler(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit(q, v, m, force, dt):
    a = force(q, v) / m
    v = v + dt * a
    return q + dt * v, v


def rk4(q, v, m, force, dt):
    def deriv(q, v):
        return v, force(q, v) / m

    k1q, k1v = deriv(q, v)
    k2q, k2v = deriv(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v)
    k3q, k3v = deriv(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v)
    k4q, k4v = deriv(q + dt * k3q, v + dt * k3v)
    return (q + (dt / 6.0) * (k1q + 2.0 * k2q + 2.0 * k3q + k4q),
            v + (dt / 6.0) * (k1v + 2.0 * k2v + 2.0 * k3v + k4v))


INTEGRATORS = {"euler": euler, "semi_implicit": semi_implicit, "rk4": rk4}


def simulate(step_fn, system, dt, steps):
    q, v = system["q0"].astype(float).copy(), system["v0"].astype(float).copy()
    trajectory, energies = np.empty((steps + 1, 3)), np.empty(steps + 1)
    trajectory[0], energies[0] = q, system["energy"](q, v)
    for i in range(steps):
        q, v = step_fn(q, v, system["m"], system["force"], dt)
        trajectory[i + 1], energies[i + 1] = q, system["energy"](q, v)
    return trajectory, energies


def main(argv=None):
    parser = argparse.ArgumentParser()
    parser.add_argument("--system", default="orbit")
    parser.add_argument("--integrator", choices=["all", *INTEGRATORS], default="all")
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--smoke", action="store_true")
    parser.add_argument("--no-rerun", dest="rerun", action="store_false")
    parser.add_argument("--out", type=Path, default=Path("outputs/baseline"))
    args = parser.parse_args(argv)
    steps = 600 if args.smoke else args.steps
    args.out.mkdir(parents=True, exist_ok=True)
    system = build_system(args.system, np.random.default_rng(0))
    if args.rerun:
        rr.init("bench-baseline", spawn=False)
        rr.save(str(args.out / "baseline.rrd"))
    drift = {}
    for name, step_fn in INTEGRATORS.items():
        if args.integrator not in ("all", name):
            continue
        trajectory, energies = simulate(step_fn, system, 0.01, steps)
        e0 = energies[0]
        drift[name] = {"rel_final": float((energies[-1] - e0) / abs(e0)),
                       "rel_max": float(np.max(np.abs(energies - e0)) / abs(e0))}
        if args.rerun:
            rr.log(f"world/{name}", rr.LineStrips3D([trajectory]), static=True)
            for i, e in enumerate(energies):
                rr.set_time("step", sequence=i)
                rr.log(f"energy/{name}", rr.Scalars([float(e)]))
    (args.out / "metrics.json").write_text(json.dumps(drift, indent=2, sort_keys=True) + "\n")
    print(json.dumps(drift))


if __name__ == "__main__":
    sys.exit(main())
