"""What the docs quote, printed by hand, and the golden files: `python tools/figures.py NAME`, NAME one of

    golden       tests/golden/smoke_NAME.json for every system (then read `git diff tests/golden` line by line)
    fingerprint  one SHA-256 over the 9 chapter runs' states (docs/DEVELOPING.md, "Determinism on any CPU")
    orders       DEVELOPING's convergence orders; damped: docs/damping.md's convergence ladder
    parity       DEVELOPING and damping.md: ours against MuJoCo 3.10.0's integrators (the 'mujoco' extra, as below)
    scan         damping.md: implicit against mjINT_IMPLICIT; rollout: docs/ensembles.md; shadow: ANSWERS.md
"""

import argparse
import functools
import hashlib
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # engine, and the helpers and models the tests use
import engine  # noqa: E402
import engine_damping  # noqa: E402
import engine_ensembles  # noqa: E402

MUJOCO_NAME = {"semi_implicit": "Euler", "rk4": "RK4"}  # mjINT_EULER is semi-implicit Euler


def orders():
    from test_closed_form import ladder, measured_orders

    for system_name in ("spring", "orbit"):
        for integrator in engine.CHAPTER_INTEGRATORS:
            found = ", ".join(f"{order:.3f}" for order in measured_orders(system_name, integrator))
            print(f"{system_name:<7}{integrator:<15}dt {ladder(integrator)[0]:g} halved 5 times: orders {found}")


def damped_convergence():
    from test_damping import damped, run_all

    system, ladders = damped(), {}
    for dt in (0.02, 0.01, 0.005, 0.0025):
        for name, (p, v, e) in run_all(system, dt, round(5.0 / dt)).items():
            audits = [engine_damping.against_exact(system, p[:n + 1], v[:n + 1], e[:n + 1], engine.kept_steps(n), dt)
                      for n in (round(t / dt) for t in (1.0, 2.0, 3.0, 4.0, 5.0))]
            ladders.setdefault(name, []).append((max(abs(a["work_mismatch"]) for a in audits),
                                                 max(a["err_max"] for a in audits)))
    print(f"damped_spring b {engine_damping.DAMPING}, 5 s, dt 0.02 halved 3 times; the worst energy audit at"
          " t = 1..5 s, and the worst |q - q_exact| over the whole run:")
    for column, what in ((0, "|E lost - damper work| / E0"), (1, "|q - q_exact|")):
        print(f"  {what}:")
        for name, ladder in ladders.items():
            values = [rung[column] for rung in ladder]
            found = [math.log2(a / b) for a, b in zip(values[:-1], values[1:], strict=True)]
            print(f"    {name:<14}" + "  ".join(f"{x:.3e}" for x in values)
                  + "   orders " + ", ".join(f"{o:.3f}" for o in found))


def parity():
    """One body of mass 1 on slide joints, dt 0.01, 2000 steps; the damped spring up to a reset or a blow-up."""
    from mujoco_models import damped_trajectory, mujoco_trajectory

    for name in ("spring", "freefall", "orbit"):
        system = engine.build_system(name, np.random.default_rng(0))
        for ours, theirs in MUJOCO_NAME.items():
            mine, _, _ = engine.simulate(engine.INTEGRATORS[ours], system, 0.01, 2000)
            gap = np.abs(mine - mujoco_trajectory(name, theirs)).max()
            print(f"{name:<9} mujoco {theirs:<6} vs {ours:<14} max |q_ours - q_mujoco| = {gap:.3g} over 2000 steps")
    pairs = (("Euler", "implicit"), ("implicitfast", "implicit"), ("implicit", "implicit"),
             ("Euler", "semi_implicit"), ("RK4", "rk4"))
    for b in (0.5, 4.0, 300.0):
        system = engine.build_system("damped_spring", np.random.default_rng(0), b)
        ours = {name: engine.simulate(step, system, 0.01, 2000)[0]
                for name, step in engine.integrators_for(system).items()}
        for theirs, mine in pairs:
            positions, reset_at = damped_trajectory(theirs, b)
            blown = np.flatnonzero(~np.isfinite(ours[mine][:, 0]))
            upto = min(len(positions), reset_at or len(positions), blown[0] if blown.size else len(positions))
            gap = np.abs(ours[mine][:upto] - positions[:upto]).max()
            notes = [f"our positions non-finite from step {blown[0]:,}; compared before that"] if blown.size else []
            if reset_at is not None:
                notes.append(f"MuJoCo blew up and reset at step {reset_at:,}; compared before that")
            print(f"damped_spring b {b:<4g} mujoco {theirs:<12} vs {mine:<14} max |q_ours - q_mujoco| = {gap:.3g}"
                  + (f" ({'; '.join(notes)})" if notes else ""))


def scan(start=1.05, dt=0.01, steps=2000):
    """Our implicit_step (it multiplies by a reciprocal) against mjINT_IMPLICIT (it divides), b = 0.1 .. 9.9."""
    import mujoco

    from mujoco_models import damped_xml, in_scratch_folder

    runs, differ, worst = 99, {"positions": 0, "velocities": 0, "either": 0}, {"positions": 0.0, "velocities": 0.0}
    for tenths in range(1, runs + 1):
        system = engine.build_system("damped_spring", np.random.default_rng(0), tenths / 10)
        system["q0"] = np.array([start, 0.0, 0.0])
        model = mujoco.MjModel.from_xml_string(damped_xml("implicit", dt, system))
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:] = system["q0"][:1], system["v0"][:1]
        theirs = np.zeros((2, steps + 1))
        theirs[:, 0] = data.qpos[0], data.qvel[0]
        with in_scratch_folder():
            for i in range(1, steps + 1):
                mujoco.mj_step(model, data)
                theirs[:, i] = data.qpos[0], data.qvel[0]
        q, v, _ = engine.simulate(engine.integrators_for(system)["implicit"], system, dt, steps)
        gaps = {"positions": np.abs(q[:, 0] - theirs[0]), "velocities": np.abs(v[:, 0] - theirs[1])}
        for what, size in (("positions", theirs[0]), ("velocities", theirs[1])):
            differ[what] += bool(gaps[what].max() > 0)
            worst[what] = max(worst[what], gaps[what].max() / np.abs(size).max() / np.finfo(float).eps)
        differ["either"] += bool(max(gap.max() for gap in gaps.values()) > 0)
    print(f"damped_spring from x = {start}, b = 0.1 to 9.9 by 0.1, dt {dt}, {steps} steps: implicit vs mjINT_IMPLICIT")
    for what in ("positions", "velocities"):
        print(f"  {what:<10} differ in {differ[what]} of {runs} runs, by at most {worst[what]:.1f} epsilons of"
              f" the motion's size")
    print(f"  either     differ in {differ['either']} of {runs} runs")


def rollout_start(system_name, integrator, dt, q0, v0):
    """(model, data, states): the system as a model with model.nq slide joints, and (N, nstate) mjSTATE_FULLPHYSICS
    states ([time, qpos, qvel] here) at time 0 from (N, 3) q0 and v0."""
    import mujoco

    from mujoco_models import xml_for

    model = mujoco.MjModel.from_xml_string(xml_for(system_name, MUJOCO_NAME[integrator], dt, 1.0))
    data, full = mujoco.MjData(model), mujoco.mjtState.mjSTATE_FULLPHYSICS.value
    states = np.empty((len(q0), mujoco.mj_stateSize(model, full)))
    for i in range(len(q0)):  # set-up only, once per member; the stepping is all in C
        mujoco.mj_resetData(model, data)
        data.qpos[:], data.qvel[:] = q0[i, :model.nq], v0[i, :model.nq]
        mujoco.mj_getState(model, data, states[i], full)
    return model, data, states


def rollout_positions(system_name, integrator, q0, v0, dt, steps):
    """(steps + 1, N, 3) positions and velocities from mujoco.rollout on one MjData (the calling thread), start
    prepended; axes the model has no joint for (the spring's y and z) keep the start, as the engine does."""
    from mujoco import rollout

    model, data, start = rollout_start(system_name, integrator, dt, q0, v0)
    state, _ = rollout.rollout(model, data, start, nstep=steps)
    dof, positions = model.nq, np.broadcast_to(q0, (steps + 1, *q0.shape)).copy()
    velocities = np.broadcast_to(v0, (steps + 1, *v0.shape)).copy()
    positions[1:, :, :dof] = state[:, :, 1:1 + dof].transpose(1, 0, 2)
    velocities[1:, :, :dof] = state[:, :, 1 + dof:1 + 2 * dof].transpose(1, 0, 2)
    return positions, velocities


def rollout_parity(seeds=1000):
    for name in ("spring", "freefall"):
        system = engine_ensembles.build_ensemble(functools.partial(engine.build_system, name), range(seeds))
        for ours in MUJOCO_NAME:
            mine, mine_v, _ = engine.simulate(engine.INTEGRATORS[ours], system, 0.01, 2000)
            theirs, theirs_v = rollout_positions(name, ours, system["q0"], system["v0"], 0.01, 2000)
            gap = max(np.abs(mine - theirs).max(), np.abs(mine_v - theirs_v).max())
            scale = max(np.abs(theirs).max(), np.abs(theirs_v).max())
            same = np.array_equal(mine, theirs) and np.array_equal(mine_v, theirs_v)
            print(f"{name:<9} {seeds} seeds x 2000 steps, {ours:<14} vs rollout mj{MUJOCO_NAME[ours]:<6}"
                  f" max gap {gap:.3g} = {gap / scale:.2g} of the motion's size ({scale:.4g})"
                  + ("  bit for bit" if same else ""))


def shadow():
    from exercises.support import shadow
    from test_ex7 import mujoco_bands

    for k, m in [(4.0, 1.0), (3.0, 2.5)]:
        energy_band, shadow_band, roundoff = mujoco_bands(k, m)
        print(f"MuJoCo mjINT_EULER, slide joint k {k:g}, m {m:g}, dt {shadow.DT}, {shadow.STEPS:,} steps:"
              f" E band {energy_band:.2e}, E~ band {shadow_band:.0e} (round-off bound {roundoff:.0e})")
    _, shadow_band, roundoff = mujoco_bands(4.0, 1.0, damping=0.5)
    print(f"the same with damping 0.5: E~ band {shadow_band:.2e} (round-off bound {roundoff:.0e})")


def golden():
    """What `python engine.py --smoke --no-rerun --system NAME` writes today: the course CI's reference."""
    with tempfile.TemporaryDirectory() as scratch:
        for name in engine.SYSTEMS:
            subprocess.run([sys.executable, str(ROOT / "engine.py"), "--smoke", "--no-rerun", "--system", name,
                            "--out", f"{scratch}/{name}"], check=True, stdout=subprocess.DEVNULL)
            target = ROOT / "tests" / "golden" / f"smoke_{name}.json"
            before = target.read_bytes() if target.exists() else None
            target.write_bytes(Path(f"{scratch}/{name}/metrics.json").read_bytes())
            print(f"{target.relative_to(ROOT)}: {'unchanged' if before == target.read_bytes() else 'WRITTEN'}")


def fingerprint():
    """The same hash under OPENBLAS_CORETYPE=Haswell or SkylakeX or NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL":
    the physics does not depend on the BLAS kernel or the SIMD level."""
    digest = hashlib.sha256()
    for system_name in ("orbit", "spring", "freefall"):
        for integrator in engine.CHAPTER_INTEGRATORS:
            system = engine.build_system(system_name, np.random.default_rng(0))
            for states in engine.simulate(engine.INTEGRATORS[integrator], system, 0.01, 2000):
                digest.update(states.tobytes())
    print(digest.hexdigest())


if __name__ == "__main__":
    run = {"golden": golden, "fingerprint": fingerprint, "orders": orders, "damped": damped_convergence,
           "parity": parity, "scan": scan, "rollout": rollout_parity, "shadow": shadow}
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("figures", choices=run)
    run[parser.parse_args().figures]()
