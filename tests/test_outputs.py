"""The course's writer (curriculum/common/outputs.py) and engine.py's files: written whole or not at all, the
previous pair kept on any failure, never through another user's link; bad --out is one line and exit 2. Real file
systems, links and processes; signals are tests/test_signals.py's; what is not defended case by case is
docs/DEVELOPING.md's limits table."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import engine as chapter
from conftest import REPO
from conftest import run as run_alone
from curriculum.common.outputs import content_id, one_line_failures, write_run

PAIR = ("engine.rrd", "metrics.json")  # recording first, the index last: the order engine.py writes them


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def previous_pair(folder: Path) -> dict:
    folder.mkdir(parents=True, exist_ok=True)
    files = {"engine.rrd": b"old recording\n", "metrics.json": b'{"old": true}\n'}
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return files


def recording_id(path: Path) -> str:
    (recording,) = pytest.importorskip("rerun.chunk").RrdReader(path).recordings()
    return recording.recording_id


# --- the writer ---


def test_both_files_are_replaced_with_the_usual_mode_and_nothing_else_is_left(tmp_path):
    out = tmp_path / "a" / "b"
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    write_run(out, {"engine.rrd": b"\x00rrd", "metrics.json": "{}\n"})
    (out / "metrics.json").unlink()
    (out / "metrics.json").symlink_to(victim)  # a link in a file's place is replaced, never followed
    write_run(out, {"engine.rrd": b"\x00rrd", "metrics.json": "{}\n"})
    assert listing(out) == sorted(PAIR) and (out / "metrics.json").read_text() == "{}\n"
    assert victim.read_text() == "precious\n" and not (out / "metrics.json").is_symlink()
    mask = os.umask(0)
    os.umask(mask)
    assert (out / "metrics.json").stat().st_mode & 0o777 == 0o666 & ~mask
    assert content_id('{"a": 1}\n') == content_id(b'{"a": 1}\n') != content_id('{"a": 2}\n')


LONG = "x" * 250  # its temporary file's name is past the 255 bytes a file system allows
FAILURES = {  # what fails -> the one line's end, and the files left; each a real failure of the OS or numpy
    "a second file that cannot be made": (
        lambda out: write_run(out, {"engine.rrd": b"new", LONG: b"new"}),
        f"File name too long; engine.rrd and {LONG} in {{out}} were left as they were", ["engine.rrd"]),
    "a second rename that cannot be made": (  # metrics.json is a folder that is not empty
        lambda out: write_run(out, {"engine.rrd": b"new", "metrics.json": b"new"}),
        "Is a directory; only engine.rrd in {out} is new", ["engine.rrd", "metrics.json"]),
    "memory": (  # 8 PiB: past any address space
        lambda out: np.empty(2**50),
        "not enough memory (MemoryError): a shorter run needs less, or raise the memory limit; no file was written",
        ["engine.rrd"]),
}


@pytest.mark.parametrize("case", FAILURES)
def test_a_failure_is_one_line_and_leaves_no_temporary_file(case, tmp_path, capsys):
    """The one top-level handler (one_line_failures) of every main(): exit 1, one line saying what is new."""
    act, says, files = FAILURES[case]
    (tmp_path / "engine.rrd").write_bytes(b"old")
    if "rename" in case:
        (tmp_path / "metrics.json" / "inside").mkdir(parents=True)
    assert one_line_failures("prog.py")(act)(tmp_path) == 1
    assert capsys.readouterr().err == f"prog.py: error: {says.format(out=tmp_path)}\n"
    assert listing(tmp_path) == files
    assert (tmp_path / "engine.rrd").read_bytes() == (b"new" if "rename" in case else b"old")


@pytest.mark.slow  # six whole engine runs
def test_runs_started_together_into_missing_folders_all_succeed(tmp_path):
    """Six at once (as a course's CI starts them), into nested folders that do not exist yet and into one folder."""
    outs = [tmp_path / "new", tmp_path / "new" / "sub", tmp_path / "new" / "sub" / "deeper"] + [tmp_path / "one"] * 3
    runs = [subprocess.Popen([sys.executable, "engine.py", "--smoke", "--no-rerun", "--seed", str(seed), "--out",
                              str(out)], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            for seed, out in enumerate(outs)]
    assert [(run.wait(timeout=120), run.stderr.read()) for run in runs] == [(0, "")] * 6
    seeds = [json.loads((out / "metrics.json").read_text())["seed"] for out in outs]
    assert seeds[:3] == [0, 1, 2] and seeds[3] in (3, 4, 5) and listing(tmp_path / "one") == ["metrics.json"]


# --- bad --out: one line, exit 2, before the run, nothing made ---

BAD_OUT = {
    "is a file": ("file", "file cannot hold files: file is a file"),
    "is under a file": ("file/sub", "file/sub cannot hold files: file is a file"),
    "under /proc": ("/proc/ch3.3-out", "cannot create a file in /proc: No such file or directory"),
    "dangling symlink": ("dangling", "cannot create a file in dangling: No such file or directory"),
    "looping symlink": ("loop", "cannot create a file in loop: Too many levels of symbolic links"),
    "metrics.json is a folder": ("taken", "metrics.json is a folder"),
    "empty": ("", "the output folder is empty"),
    "a control character": ("a\x1b[2Jb", "'a\\x1b[2Jb' holds a control character"),
    "a byte that is not text": ("a\udcffb", "'a\\udcffb' holds a control character or a byte that is not text"),
}


@pytest.mark.parametrize("case", BAD_OUT)
def test_an_out_that_cannot_take_the_files_is_one_line_before_the_run(case, tmp_path, monkeypatch, capsys):
    out, words = BAD_OUT[case]
    (tmp_path / "file").touch()
    (tmp_path / "dangling").symlink_to("nowhere")
    (tmp_path / "loop").symlink_to("loop")
    (tmp_path / "taken" / "metrics.json").mkdir(parents=True)
    before = sorted(tmp_path.rglob("*"))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        chapter.main(["--steps", "10000000", "--no-rerun", "--out", out])  # refused before 10 M steps
    err = capsys.readouterr().err
    assert stop.value.code == 2 and len(err.splitlines()) == 1 and "--out" in err
    assert words in err and sorted(tmp_path.rglob("*")) == before


OTHER_USER = 65533  # any uid but ours and nobody's: the user who plants the link


def test_a_symlink_another_user_planted_in_a_sticky_folder_is_refused(tmp_path, capsys):
    """A sticky folder everyone may write to (like /tmp), where another user made `out` -> a folder of theirs;
    `mine` is our own link leading to theirs. (Linux's fs.protected_symlinks, off on some machines, would refuse.)"""
    if os.geteuid() != 0:
        pytest.skip("making a link that belongs to another user needs root")
    shared, theirs = tmp_path / "shared", tmp_path / "theirs"
    shared.mkdir(mode=0o1777)
    shared.chmod(0o1777)
    (theirs / "deeper").mkdir(parents=True)
    (theirs / "metrics.json").write_text("theirs\n")
    (shared / "out").symlink_to(theirs)
    (tmp_path / "mine").symlink_to(shared / "out")
    for path in (theirs, theirs / "deeper", theirs / "metrics.json", shared / "out"):
        os.lchown(path, OTHER_USER, OTHER_USER)
    for out in ("shared/out", "shared/out/deeper", "mine"):
        with pytest.raises(SystemExit) as stop:
            chapter.main(["--smoke", "--no-rerun", "--out", str(tmp_path / out)])
        err = capsys.readouterr().err
        assert stop.value.code == 2 and len(err.splitlines()) == 1 and "argument --out" in err
        assert f"goes through {shared / 'out'}, a symbolic link of user {OTHER_USER} in a shared sticky folder" in err
        with pytest.raises(PermissionError):  # the writer checks again: a link planted after the check
            write_run(tmp_path / out, {"metrics.json": "{}\n"})
    assert listing(theirs) == ["deeper", "metrics.json"] and listing(theirs / "deeper") == []
    assert (theirs / "metrics.json").read_text() == "theirs\n"
    os.lchown(shared / "out", os.geteuid(), os.getegid())  # our own link in a shared folder is followed
    write_run(tmp_path / "mine", {"metrics.json": "{}\n"})
    assert (theirs / "metrics.json").read_text() == "{}\n"


# --- the run's numbers at the edges: the files are still written, strict JSON ---


def run_here(capsys, *args) -> tuple:
    """engine.main(args) in this process with every warning an error: (exit code, stdout, stderr)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code = chapter.main([str(arg) for arg in args])
    printed = capsys.readouterr()
    return code, printed.out, printed.err


def strict_json(path: Path) -> dict:
    return json.loads(path.read_text(), parse_constant=lambda constant: pytest.fail(f"{constant} in {path}"))


VERDICTS = {  # flags -> what the report says of the ordering
    "drifts that overflow": (["--dt", "1.33e154", "--steps", "1"], "diverged: energy overflowed at step 1"),
    "semi-implicit out of its band": (["--dt", "2"], "cannot judge, semi_implicit left its band (rel_max {rel_max:.3g};"
                                                     " try a smaller --dt)"),
    "a run too short to drift": (["--dt", "1e-300", "--steps", "3"], "cannot judge, every drift is round-off (more"
                                                                     " --steps or a larger --dt)"),
    "a run that does not move": (["--dt", "1e-9", "--steps", "10"], "cannot judge, every drift is round-off"),
    "a small drift": (["--dt", "1e-6", "--steps", "100"], "as expected"),
}


@pytest.mark.parametrize("case", VERDICTS)
def test_the_verdict_judges_only_what_the_drifts_can_tell(case, tmp_path, capsys):
    """Not 'UNEXPECTED' for drifts that are round-off, overflowed or out of semi-implicit Euler's band."""
    flags, said = VERDICTS[case]
    code, out, err = run_here(capsys, *flags, "--no-rerun", "--out", tmp_path)
    drift = strict_json(tmp_path / "metrics.json")["drift"]
    assert code == 0 and (err == "" or "too small to move" in err) and said.format(**drift["semi_implicit"]) in out
    if case == "drifts that overflow":  # finite energies whose relative error overflows
        assert all(drift[name]["diverged"] and drift[name]["energy_overflow_step"] == 1 for name in ("euler",
                                                                                                    "semi_implicit"))
        assert "cannot judge" in out
    if case == "semi-implicit out of its band":
        assert not drift["semi_implicit"]["diverged"] and drift["semi_implicit"]["rel_max"] > 1.0


@pytest.mark.parametrize("members", [3, 4])  # an odd and an even count: the median of two values can overflow
def test_an_ensemble_whose_drifts_overflow_counts_them_as_diverged(members, tmp_path, capsys):
    code, _, err = run_here(capsys, "--ensemble", members, "--dt", "1.33e154", "--steps", "1", "--out", tmp_path)
    assert code == 0 and err == ""
    block = strict_json(tmp_path / "metrics.json")["ensemble"]
    single = {name: [chapter.energy_drift(run_alone("orbit", name, dt=1.33e154, steps=1, seed=seed)[2])["diverged"]
                     for seed in range(members)] for name in block["drift"]}
    assert {name: drift["diverged"] for name, drift in block["drift"].items()} == \
           {name: sum(flags) for name, flags in single.items()}
    assert single["euler"][0]  # seed 0's euler: finite energies whose relative error overflows


@pytest.mark.parametrize("system", list(chapter.SYSTEMS))
def test_a_timestep_too_small_to_move_the_state_is_warned_about(system, tmp_path, capsys):
    code, _, err = run_here(capsys, "--dt", "1e-320", "--system", system, "--no-rerun", "--out", tmp_path)
    assert code == 0
    assert err.startswith("engine.py: warning: --dt 1e-320 is too small to move the state") and err.count("\n") == 1
    assert run_here(capsys, "--dt", "1e-3", "--system", system, "--no-rerun", "--out", tmp_path)[2] == ""


def test_a_no_rerun_run_beside_an_older_recording_says_so_on_stdout(tmp_path, capsys):
    assert run_here(capsys, "--smoke", "--out", tmp_path)[0] == 0
    code, out, err = run_here(capsys, "--smoke", "--no-rerun", "--seed", "1", "--out", tmp_path)
    assert code == 0 and err == ""
    notes = [line for line in out.splitlines() if "engine.rrd" in line]
    assert notes == [f"note: {tmp_path / 'engine.rrd'} is from an earlier run (this one wrote no recording)"]
    assert recording_id(tmp_path / "engine.rrd") != strict_json(tmp_path / "metrics.json")["run_id"]


@pytest.mark.parametrize("flags", [["--system", "damped_spring", "--dt", "100", "--damping", "1e6", "--steps", "5"],
                                   ["--system", "damped_spring", "--dt", "1e12", "--steps", "3"],
                                   ["--dt", "1e-320", "--ensemble", "3"]])
def test_overflowing_and_unmoving_runs_write_their_files(flags, tmp_path, capsys):
    """numpy's round() of a float64 past 1.8e296 gave inf, which strict JSON refused after the run; an ensemble
    whose every error is log10(0) gave the recording no range to unpack. Both were tracebacks."""
    assert chapter.main([*flags, "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    assert recording_id(tmp_path / "engine.rrd") == strict_json(tmp_path / "metrics.json")["run_id"]
