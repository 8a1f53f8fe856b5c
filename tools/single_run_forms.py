"""The default run in the forms tools/bench_single_run.py compares, one per fresh interpreter:

    python tools/single_run_forms.py FORM ROOT OUT

FORM is batched, one body or chapter (see tools/bench_single_run.py); ROOT is the folder whose engine.py
runs, this checkout or an earlier commit's tree; OUT is the output folder. engine.py is imported as a
module in every form, and nothing but sys before it, so every form pays the same for the harness.
"""

import sys


def run_form(form: str, root: str, out: str) -> int:
    """engine.main() on the default flags, from root/engine.py, with the one-body patches `form` names."""
    sys.path.insert(0, root)
    import numpy as np

    import engine

    if form in ("one body", "chapter"):
        build_system = engine.build_system

        def build_one_body(name, rng, *args):
            system = build_system(name, rng, *args)
            if name == "orbit":
                mu, m = 1.0, system["m"]  # engine.py's orbit: GM = mu = 1

                def force(q, v):
                    r = np.sqrt(engine.dot3(q, q))
                    return -mu * m * q / (r * r * r)  # one body: r is one number, no [..., None]

                system = {**system, "force": force}
            return system

        engine.build_system = build_one_body
    if form == "chapter":

        def simulate_every_step(step_fn, system, dt, steps, every=1, progress=None):
            assert every == 1, "the default run keeps every state"
            q, v = np.array(system["q0"], dtype=float), np.array(system["v0"], dtype=float)
            m, force, energy = system["m"], system["force"], system["energy"]
            positions, velocities, energies = np.empty((steps + 1, 3)), np.empty((steps + 1, 3)), np.empty(steps + 1)
            positions[0], velocities[0], energies[0] = q, v, energy(q, v)
            with np.errstate(all="ignore"):
                for i in range(1, steps + 1):
                    q, v = step_fn(q, v, m, force, dt)
                    positions[i], velocities[i], energies[i] = q, v, energy(q, v)
            return positions, velocities, energies

        engine.simulate = simulate_every_step
    return engine.main(["--out", out])


if __name__ == "__main__":
    sys.exit(run_form(*sys.argv[1:]))
