"""What a student reads before predicting gives no answer away, and every command printed in the READMEs runs.

The answers are read from exercises/solutions/ANSWERS.md (pasted from runs), so when the physics changes the
test follows; the texts searched are README.md, exercises/README.md, exercises/HINTS.md, every exercise's
--help, module docstring and bare question, and the integrators' docstrings. Exercise 1's answer is what the
chapter is about, so README states it too, but only after asking the student to do the exercise: the phrases
that give it away are searched for in what comes before.
"""

import ast
import contextlib
import functools
import importlib
import io
import re
import shlex
import subprocess
import sys

import pytest

from conftest import REPO, run
from curriculum.common import report
from curriculum.common.exercise import exercises

ANSWERS = (REPO / "exercises" / "solutions" / "ANSWERS.md").read_text()
PRISTINE_STUB = REPO / "exercises" / "support" / "pristine" / "ex2_integrators.py"
EXERCISES = exercises(REPO / "exercises")  # found by file name: a new exercise is read here without an edit
PREDICT_THEN_RUN = [name for _, name, kind in EXERCISES if kind == "predict"]
CHECKERS = [f"check_ex{number}" for number, _, kind in EXERCISES if kind == "code"]
EXERCISE_MODULES = [name for _, name, _ in EXERCISES] + CHECKERS


def section(heading: str) -> str:
    return ANSWERS.split(f"## {heading}")[1].split("\n## ")[0]


def graded_answers() -> dict:
    """The answers that score, as ANSWERS.md shows them scoring."""
    ex1 = re.search(r"The graded answer is `([^`]+)`", section("Exercise 1")).group(1)
    ex3 = re.search(r"--predict (\S+)`", section("Exercise 3")).group(1)
    assert f"Right: {ex3.replace('=', ' ').replace(',', ', ')}." in section("Exercise 3")
    ex4 = int(re.search(r"Right: it is about ([\d,]+) orbits", section("Exercise 4")).group(1).replace(",", ""))
    ex5 = re.search(r"The graded answer is `([^`]+)`", section("Exercise 5")).group(1)
    return {"ex1": dict(item.strip().split("=") for item in ex1.split(",")),
            "ex3": dict(item.split("=") for item in ex3.split(",")), "ex4": ex4,
            "ex5": dict(item.strip().split("=") for item in ex5.split(","))}


def measured_figures() -> set:
    """Every measured number exercises 3 and 4 print (ladder factors, bands, crossover steps, orbit counts)."""
    blocks = re.findall(r"```\n(.*?)```", section("Exercise 3") + section("Exercise 4"), flags=re.S)
    numbers = set(re.findall(r"\d[\d,]*\.\d+(?:e[-+]\d+)?|\d{1,3}(?:,\d{3})+|\b\d{3,}\b", "".join(blocks)))
    inputs = {"2000", "2,000", "1,000", "10,000", "100,000"}  # the chapter's run and the choices: not answers
    significant = {n for n in numbers if len(re.sub(r"e.*|\D|^[0.]+", "", n)) >= 3}  # 1.99, 727; not dt 0.25
    return significant - inputs


def spoilers() -> list:
    """(pattern, what it would give away)."""
    answers = graded_answers()
    ex4 = answers["ex4"]
    patterns = [
        (rf"--predict\s+(1e{len(str(ex4)) - 1}|{ex4:,}|{ex4}|{ex4:_})\b", "exercise 4's answer as a --predict example"),
        (rf"\b({ex4:,}|{ex4}) orbits", "exercise 4's orbit count"),
        (r"(shrinks?|divides?|drops?|falls?)( \w+){0,4} by (about |roughly )?(2|4|16|32|sixteen|two)\b",
         "a shrink factor"),
        (r"\bfactors? (of )?(2|16|32)\b", "a shrink factor"),
        (r"\b(millions|thousands) of (orbits|times)", "exercise 4's scale"),
    ]
    for name, word in answers["ex1"].items():
        patterns.append((rf"\b{name}\s*[=:]\s*{word}\b", "exercise 1's graded answer"))
    for name, factor in answers["ex3"].items():
        patterns.append((rf"\b{name}\s*=\s*{factor}\b", "exercise 3's graded factor"))
    for name, word in answers["ex5"].items():
        patterns.append((rf"\b{name}\s*[=:]\s*{word}\b", "exercise 5's graded answer"))
    patterns.append((r"\b(keeps?|preserves?|conserves?) (the |its )?(phase[- ]space )?area|area[- ]preserving",
                     "exercise 5's answer for semi-implicit Euler"))
    for figure in measured_figures():
        patterns.append((rf"(?<![\d.,]){re.escape(figure)}(?![\d])", f"the measured figure {figure}"))
    for number, graded in re.findall(r"## Exercise (\d+).*?The graded answer is `([^`]+)`", ANSWERS, flags=re.S):
        for name, value in re.findall(r"(\w+)\s*=\s*([\w.]+)", graded):  # any exercise's name=value answers
            patterns.append((rf"\b{name}\s*[=:]\s*{value}\b", f"exercise {number}'s graded answer"))
    return patterns


# What gives exercise 1's answer away in words: the sentences README, HINTS and the docstrings used to say.
# (The question's own words, "grow with the run" and "stay in a band", are not among them.)
EX1_GIVEAWAYS = [r"spiral(s|ling)? out", r"\bonly (ever )?(grows|climbs|goes up)", r"band that does not grow",
                 r"(wobbles|oscillates) (in|inside) a band|\binside a band", r"\bcreeps?\b",
                 r"(comes|pulled|brought) back", r"adds energy", r"\bruns? away|\brunaway", r"(has )?one sign",
                 r"climbing without bound", r"\bunbounded\b"]


def before_exercise_1() -> dict:
    """{where: text} for what a student reads before exercise 1 asks: README up to its request to do the
    exercise, exercises/README up to exercise 2, HINTS' exercise 1, the exercise's own texts, the integrators'
    docstrings (engine.py is the chapter, open beside it)."""
    import engine

    readme = (REPO / "README.md").read_text()
    texts = {"README.md up to 'do exercise 1'": readme[: readme.index("do exercise 1")],
             "exercises/README.md up to exercise 2": (REPO / "exercises" / "README.md").read_text().split("## 2.")[0],
             "exercises/HINTS.md, exercise 1": (REPO / "exercises" / "HINTS.md").read_text().split("## Exercise 2")[0]}
    texts.update({f"{step.__name__} docstring": step.__doc__ for step in engine.INTEGRATORS.values()})
    return texts | {where: text for where, text in exercise_texts().items() if "ex1_band" in where}


def exercise_texts() -> dict:
    """{where: text} for everything a student reads before committing to a prediction."""
    # Output blocks (the chapter's drift table, the exercises' timings) are measurements of the chapter, not
    # answers; prose and ```bash blocks are where the old spoilers were.
    def without_output_blocks(text):
        return re.sub(r"```(\w*)\n.*?```", lambda block: block.group(0) if block.group(1) else "", text, flags=re.S)

    texts = {name: without_output_blocks((REPO / name).read_text())
             for name in ("README.md", "exercises/README.md", "exercises/HINTS.md")}
    for module_name in EXERCISE_MODULES:  # the stub as a student first opens it: the pristine copy, not their edits
        if module_name == PRISTINE_STUB.stem:
            texts["exercises/ex2_integrators.py docstring"] = ast.get_docstring(ast.parse(PRISTINE_STUB.read_text()))
            continue
        module = importlib.import_module(f"exercises.{module_name}")
        texts[f"exercises/{module_name}.py docstring"] = module.__doc__
    for module_name in [*PREDICT_THEN_RUN, *CHECKERS]:
        module = importlib.import_module(f"exercises.{module_name}")
        for argv, what in ((["--help"], "--help"), ([], "bare question")):
            if module_name in CHECKERS and not argv:
                continue  # bare, the checker checks: it asks nothing
            out = io.StringIO()
            with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
                module.main(argv)
            texts[f"python -m exercises.{module_name} {' '.join(argv)} ({what})"] = out.getvalue()
    return texts


def test_the_answers_are_where_teachers_find_them():
    answers = graded_answers()
    assert answers["ex1"] == {"euler": "grows", "semi_implicit": "stays", "rk4": "grows"}
    assert set(answers["ex3"]) == {"euler", "semi_implicit", "rk4"}
    assert len(measured_figures()) > 40
    assert "python -m exercises.ex4_long_run --predict" in section("Exercise 4")


@pytest.mark.parametrize("number, module", [(n, m) for n, m, kind in EXERCISES if kind == "predict"])
def test_every_predict_then_run_exercise_has_its_answer_for_teachers(number, module):
    """An exercise is its file, its section in exercises/README.md and its section in ANSWERS.md: this names the
    section that is missing, with the command and the output a teacher reads (pasted from a run)."""
    assert f"## Exercise {number}" in ANSWERS, f"exercises/solutions/ANSWERS.md has no '## Exercise {number}' section"
    commands = [command for command, _ in answers_with_their_commands() if f"-m exercises.{module} " in command]
    assert commands, (f"ANSWERS.md's exercise {number} shows no `python -m exercises.{module} --predict ...` line"
                      " with the output it prints below it")
    assert all("--predict" in command for command in commands)


def test_nothing_a_student_reads_first_gives_an_answer_away():
    import engine

    leaks = []
    texts = exercise_texts() | {f"{step.__name__} docstring": step.__doc__ for step in engine.INTEGRATORS.values()}
    for where, text in texts.items():
        for pattern, what in spoilers():
            for match in re.finditer(pattern, text, flags=re.I):
                line = text[: match.start()].count("\n") + 1
                leaks.append(f"{where}, line {line}: {what}: {match.group(0)!r}")
    assert not leaks, "\n".join(leaks)


def test_nothing_before_exercise_1_says_in_words_which_error_grows():
    leaks = [f"{where}: {match.group(0)!r}" for where, text in before_exercise_1().items()
             for pattern in EX1_GIVEAWAYS for match in re.finditer(pattern, text, flags=re.I)]
    assert not leaks, "\n".join(leaks)


def test_readme_shows_the_measurement_then_asks_exercise_1_then_interprets():
    readme = (REPO / "README.md").read_text()
    table, ask, interpretation = (readme.index("rel_final       rel_max"), readme.index("do exercise 1"),
                                  readme.index("What exercise 1 measures"))
    assert table < ask < interpretation and "python -m exercises.ex1_band" in readme[ask:interpretation]
    assert any(re.search(pattern, readme[interpretation:], flags=re.I) for pattern in EX1_GIVEAWAYS)  # still told


def test_the_spoiler_patterns_catch_the_old_leaks():
    """The texts that leaked before this test existed (issue 7) must be caught, or the test proves nothing."""
    old = ["python -m exercises.ex1_band --predict euler=grows,semi_implicit=stays,rk4=grows",
           "python -m exercises.ex3_halve_dt --predict euler=2,semi_implicit=2,rk4=16",
           "the final-position error on the orbit settles at 1.99 (Euler), 1.97 (semi-implicit) and 17.36 (RK4)",
           "RK4's error drops by about sixteen", "Euler's error roughly halves and RK4's drops by 16",
           "python -m exercises.ex4_long_run --predict 1,000", "after 727 orbits", "about 1,000 orbits"]
    for text in old:
        assert any(re.search(pattern, text, flags=re.I) for pattern, _ in spoilers()), text
    old_ex1 = ["Explicit Euler's worst excursion is its final one: the error only grows, and the orbit spirals out.",
               "Fails on anything that oscillates: it adds energy every step, so orbits spiral out.",
               "Energy wobbles in a band that does not grow; it fails where motion never returns (freefall).",
               "Tiny error per step, but it creeps one way and is never pulled back over long runs.",
               "Which of the three integrators sends the Kepler orbit's energy climbing without bound?"]
    for text in old_ex1:
        assert any(re.search(pattern, text, flags=re.I) for pattern in EX1_GIVEAWAYS), text


# --- every command printed in the READMEs runs as written, from the repo root ---

PLACEHOLDERS = {"<integrator>": "rk4", "<orbits>": "10", "=?": "=1", "=<word>": "=stays",
                "path/to/your_file.py": "tests/planted/right_stacked.py"}
# Quick: the bare questions and the checker. Slow (-m slow): the engine runs (test_cli.py runs those bare) and
# the measuring runs, whose output tests/test_exercises.py checks with other predictions.
SLOW = ("engine.py", "--predict")


def printed_commands() -> list:
    """Every `python ...` line in a ```bash block of the two READMEs, comment and `cd`/`pip ... &&` prefixes off."""
    commands = []
    for readme in ("README.md", "exercises/README.md"):
        for block in re.findall(r"```bash\n(.*?)```", (REPO / readme).read_text(), flags=re.S):
            for line in block.splitlines():
                command = re.sub(r"\s+#.*$", "", line).split("&&")[-1].strip()
                if command.startswith("python "):
                    commands.append((readme, command))
    return commands


def test_the_readmes_print_the_commands_we_expect():
    commands = [c for _, c in printed_commands()]
    for module in [*PREDICT_THEN_RUN, *CHECKERS]:
        assert any(f"python -m exercises.{module}" in c for c in commands), \
            f"exercises/README.md shows no command for {module}: give it a section with its commands"
    assert any(c.startswith("python engine.py") for c in commands)


@pytest.mark.parametrize("readme, command", [
    pytest.param(*rc, marks=pytest.mark.slow if any(s in rc[1] for s in SLOW) else ())
    for rc in printed_commands()])
def test_every_printed_command_runs_as_written(readme, command, tmp_path):
    """Placeholders get a value; engine runs write to a scratch --out (test_cli.py runs them quick and bare)."""
    for placeholder, value in PLACEHOLDERS.items():
        command = command.replace(placeholder, value)
    argv = shlex.split(command)
    if "--predict" in argv and "<" in argv[argv.index("--predict") + 1]:  # a placeholder this test has no value for:
        pasted = [c for c, _ in answers_with_their_commands() if c.startswith(" ".join(argv[:3]) + " --predict")]
        assert pasted, f"{command}: ANSWERS.md pastes no --predict run of {argv[2]} to take a prediction from"
        argv[argv.index("--predict") + 1] = shlex.split(pasted[0])[4]  # the one its ANSWERS.md section pastes
    if argv[1] == "engine.py" and "--help" not in argv:
        argv += ["--out", str(tmp_path / "out")]
    if "exercises.ex5_phase_blob" in argv and "--predict" in argv:
        argv += ["--rrd", str(tmp_path / "ex5_blob.rrd")]  # its recording goes to scratch too
    if "--handin" in argv:
        argv += ["--out", str(tmp_path / "handin.zip")]  # and the archive
    result = subprocess.run([sys.executable, *argv[1:]], cwd=REPO, capture_output=True, text=True, timeout=600)
    expected = {0, 1} if "check_ex2" in command else {0}  # a bare question too: asking is not an error
    assert result.returncode in expected, f"{readme}: {command}\n{result.stdout}\n{result.stderr}"
    assert "Traceback" not in result.stdout + result.stderr and "Error" not in result.stderr


@pytest.mark.parametrize("module", [*PREDICT_THEN_RUN, *CHECKERS])
@pytest.mark.parametrize("inside", [False, True], ids=["from the root", "from inside exercises"])
def test_every_exercise_runs_as_a_file_too(module, inside):
    """`python exercises/ex1_band.py` from the root, or `cd exercises && python ex1_band.py`: the first
    lines of each file (curriculum.common.exercise.start) make both work."""
    cwd, script = (REPO / "exercises", f"{module}.py") if inside else (REPO, f"exercises/{module}.py")
    result = subprocess.run([sys.executable, script, *(["--help"] if module in CHECKERS else [])], cwd=cwd,
                            capture_output=True, text=True, timeout=60)
    assert result.stderr == ""
    if module in CHECKERS:
        assert result.returncode == 0 and "usage:" in result.stdout
    else:
        assert result.returncode == 0 and f"python {script} --predict ANSWER" in result.stdout


def answers_with_their_commands() -> list:
    """(command, pasted output) for every output block in ANSWERS.md, from the `python ...` line above it."""
    pairs = re.findall(r"`(python [^`]+)`[^`\n]*\n\n```\n(.*?)```", ANSWERS, flags=re.S)
    return [(command, output) for command, output in pairs]


def test_every_answer_block_says_which_command_printed_it():
    assert len(answers_with_their_commands()) == ANSWERS.count("```\n") // 2 >= 5


@pytest.mark.slow
@pytest.mark.parametrize("command, pasted", answers_with_their_commands())
def test_the_answers_are_what_the_commands_print_today(command, pasted):
    """The physics is deterministic, so the teachers' figures must be reproduced to the last digit."""
    result = subprocess.run([sys.executable, *shlex.split(command)[1:]], cwd=REPO, capture_output=True, text=True,
                            timeout=600)
    assert result.stdout == pasted, f"{command}: ANSWERS.md is out of date; paste the new output"


def test_metrics_json_says_0_0_where_readme_says_so():
    """README: from --dt 0.004 down RK4's drift "rounds to `0.0` in the file": never `-0.0`."""
    import json
    import math


    assert "which rounds to `0.0` in the file" in " ".join((REPO / "README.md").read_text().split())
    written = json.loads(report.metrics_text(report.rounded({"rel_final": -4.4e-13, "rel_max": [-0.0, 1e-13]})))
    assert written == {"rel_final": 0.0, "rel_max": [0.0, 0.0]}
    assert all(math.copysign(1.0, x) == 1.0 for x in [written["rel_final"], *written["rel_max"]])


def test_ci_builds_its_own_environment_and_leaves_the_students_venv_alone():
    """README tells a student to create .venv; `bash .ci/run` must neither delete nor reuse it."""
    code = [line for line in (REPO / ".ci" / "run").read_text().splitlines() if not line.lstrip().startswith("#")]
    assert not any(re.search(r"(?<![\w/])\.venv\b", line) for line in code), "\n".join(code)
    created = re.search(r"python3 -m venv (\S+)", "\n".join(code)).group(1)
    assert f"{created}/" in (REPO / ".gitignore").read_text().splitlines()
    assert "python3 -m venv .venv" in (REPO / "README.md").read_text()


def test_the_ensemble_report_says_truly_what_a_seed_changes():
    """engine_ensembles.SEED_CHANGES ('the orbit's starting speed, 1 +- 0.05') against engine.build_system's draws."""
    import numpy as np

    import engine
    from engine_ensembles import SEED_CHANGES, jittered

    assert set(SEED_CHANGES) <= set(engine.SYSTEMS)  # a system without words is described by jittered()
    assert jittered(functools.partial(engine.build_system, "orbit")) == "the start's v0's y"
    for name, said in SEED_CHANGES.items():
        centre, spread = map(float, re.search(r"([\d.]+) \+- ([\d.]+)", said).groups())
        starts = [engine.build_system(name, np.random.default_rng(seed)) for seed in range(1000)]
        state = np.array([np.concatenate([s["q0"], s["v0"]]) for s in starts])  # (seeds, q0 then v0)
        varies = np.flatnonzero(np.ptp(state, axis=0) > 0)
        assert len(varies) == 1, (name, varies)  # one number per system, nothing else moves
        assert ("speed" in said) == (varies[0] >= 3) and ("stretch" in said) == (varies[0] < 3)
        drawn = state[:, varies[0]]
        assert np.all(np.abs(drawn - centre) <= spread) and np.ptp(drawn) > 1.9 * spread, name


def test_the_ensemble_lines_read_true_for_one_member_and_just_over_the_limit(capsys, tmp_path):
    import engine
    from engine_ensembles import ENSEMBLE_MEMORY, ensemble_bytes, ensemble_most_members, memory_over_limit

    most = ensemble_most_members(2000)
    needed = ensemble_bytes(2000, most + 1)  # the first count over the limit at 2,000 steps
    assert needed > ENSEMBLE_MEMORY >= ensemble_bytes(2000, most)
    shown = memory_over_limit(needed)  # was "1.0 GB, over the 1 GB": a need that read as the limit itself
    assert shown.endswith(" GB, over the 1 GB") and float(shown.split()[0]) > 1.0
    assert memory_over_limit(2.04e9) == "2.0 GB, over the 1 GB"
    assert engine.main(["--ensemble", "1", "--no-rerun", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "1 member stepped together" in out and "holds for 1 of 1 seed\n" in out


@pytest.mark.slow
def test_readmes_interpretation_of_exercise_1_is_what_exercise_1_measures():
    from exercises import ex1_band

    text = " ".join((REPO / "README.md").read_text().split())
    told = text[text.index("What exercise 1 measures"):text.index("`metrics.json` holds")]
    table = ex1_band.measure()
    euler, semi, rk4 = table["euler"], table["semi_implicit"], table["rk4"]
    above, ends_below = ex1_band.rk4_above_e0()
    figures = [f"{euler[0][1]:.1%} after 2,000 steps", f"{euler[-1][1]:.1%} after 32,000",
               f"from {semi[0][0]:.3%} to {semi[0][1]:+.3%}", f"{semi[0][1] / rk4[0][0] * -1 / 1e6:.1f} million times",
               f"{ex1_band.widening(rk4[:1] + rk4[-1:]):.0f} times as big after 16 times",
               f"{above} of the 1,000 runs go above the start", f"all {ends_below:,} end below it",
               f"widens it by {round((ex1_band.widening(semi[:1] + semi[-1:]) - 1) * 1e7)} parts in 10 million"]
    for figure in figures:
        assert figure in told, figure


@pytest.mark.slow
def test_readmes_round_off_digits_are_what_exact_arithmetic_says():
    """README: RK4's -4.5061e-11 and 5.1299e-11 are -4.5066e-11 and 5.1303e-11 with the same steps in 50 digits."""
    from decimal import Decimal, localcontext

    import numpy as np

    import engine

    system = engine.build_system("orbit", np.random.default_rng(0))
    with localcontext() as context:
        context.prec = 50
        q, v, dt = [Decimal(x) for x in system["q0"][:2]], [Decimal(x) for x in system["v0"][:2]], Decimal(0.01)

        def pull(q):
            r2 = q[0] * q[0] + q[1] * q[1]
            return [-x / (r2 * r2.sqrt()) for x in q]

        def energy(q, v):
            return (v[0] * v[0] + v[1] * v[1]) / 2 - 1 / (q[0] * q[0] + q[1] * q[1]).sqrt()

        def moved(a, b, h):
            return [x + h * y for x, y in zip(a, b, strict=True)]

        e0, errors = energy(q, v), []
        for _ in range(2000):
            k1q, k1v = v, pull(q)
            k2q, k2v = moved(v, k1v, dt / 2), pull(moved(q, k1q, dt / 2))
            k3q, k3v = moved(v, k2v, dt / 2), pull(moved(q, k2q, dt / 2))
            k4q, k4v = moved(v, k3v, dt), pull(moved(q, k3q, dt))
            q = [x + dt / 6 * (a + 2 * b + 2 * c + d) for x, a, b, c, d in zip(q, k1q, k2q, k3q, k4q, strict=True)]
            v = [x + dt / 6 * (a + 2 * b + 2 * c + d) for x, a, b, c, d in zip(v, k1v, k2v, k3v, k4v, strict=True)]
            errors.append((energy(q, v) - e0) / abs(e0))
    readme = (REPO / "README.md").read_text()
    exact_final, exact_max = float(errors[-1]), float(max(abs(e) for e in errors))
    assert f"give {exact_final:.4e} and {exact_max:.4e}" in " ".join(readme.split())
    drift = engine.energy_drift(run("orbit", "rk4")[2])
    assert f"{drift['rel_final']:.4e}" != f"{exact_final:.4e}" and f"{drift['rel_final']:.2e}" == f"{exact_final:.2e}"


def test_the_bounded_intervals_are_closed_except_at_w_2():
    """docs/damping.md and exercise 6: at an interval's end an eigenvalue has modulus 1 and the run stays bounded
    (the four end cells of exercise 6's map), except at w = 2, where both eigenvalues are -1 and it grows."""
    import numpy as np

    from exercises.support import stability_map

    ends = [("euler", 1.0, 1.0), ("euler", 1.0, 2.5), ("semi_implicit", 1.0, 1.5), ("implicit", 3.0, 2.5)]
    for name, w, c in ends:
        low, high = stability_map.analytic_interval(name, w)
        assert c in (low, high)
        assert stability_map.stays_bounded(name, np.array([w]), np.array([c]), steps=20_000)[0], (name, w, c)
    for name, c in (("euler", 4.0), ("semi_implicit", 0.0), ("implicit", 0.0)):
        assert not stability_map.stays_bounded(name, np.array([2.0]), np.array([c]), steps=20_000)[0], (name, c)
    assert [stability_map.analytic_interval(name, 2.0) for name in ("euler", "semi_implicit")] == [None, None]
    text = " ".join((REPO / "docs" / "damping.md").read_text().split())
    assert "every interval is closed" in text and "w² ≤ c ≤ 2 + w²/2" in text


@pytest.mark.parametrize("tool, doc", [("closed_form_orders", "docs/DEVELOPING.md"),
                                       ("damped_convergence", "docs/damping.md"),
                                       ("mujoco_parity", "docs/DEVELOPING.md docs/damping.md")])
def test_the_figures_a_maintainer_prints_by_hand_come_from_tools_and_are_the_docs(tool, doc, tmp_path):
    """What is run by hand sits in tools/ (tests/ holds tests and the modules they import); each figure it
    prints is pasted in the page that quotes it."""
    if tool.startswith("mujoco"):
        pytest.importorskip("mujoco", reason="needs the 'mujoco' extra")
    result = subprocess.run([sys.executable, str(REPO / "tools" / f"{tool}.py")], cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    pages = "".join((REPO / page).read_text() for page in doc.split())
    figures = [line for line in result.stdout.splitlines() if "orders" in line or "|q_ours" in line]
    assert figures and not [line for line in figures if line not in pages]
